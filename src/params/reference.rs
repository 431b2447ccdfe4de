//! Each parameter declared once, by the field that reads it: its key and
//! type from the struct, its description from the field's doc comment, its
//! accepted range from the field's `#[schemars(range(..))]` (or
//! `exclusiveMinimum`/`exclusiveMaximum`), through `schemars`. The struct's
//! check calls [`check_ranges`]; the ROS nodes describe their parameters
//! with [`params_of`], and docs/parameters.md lists them
//! ([`crate::nodes::param_reference`]).

use schemars::JsonSchema;
use serde::Serialize;
use serde_json::{Map, Value};

use super::{invalid, ParamsError};

/// One parameter: its dotted key (`<name>` where a map takes any key), its
/// type and its description.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamDoc {
    /// The dotted key, e.g. `pd.max_speed_mps` or `objects.<name>.friction`.
    pub key: String,
    /// Its type: number, integer, boolean, string, a list of one of them.
    pub kind: String,
    /// What it is, from its field's doc comment (one line).
    pub description: String,
    /// The values it accepts (`> 0`, `>= 0, <= 60`; empty: any), from its
    /// field's `#[schemars(range(..))]` or `exclusiveMinimum`.
    pub range: String,
}

/// Every parameter `T` reads, its keys under `prefix` (`""`: at the top).
pub fn params_of<T: JsonSchema>(prefix: &str) -> Vec<ParamDoc> {
    let schema = schemars::schema_for!(T);
    let root = schema.as_value();
    let mut out = Vec::new();
    leaves(root, root, prefix, "", &mut out);
    out
}

/// The description of the flat parameter `name` among `docs`: its own, or
/// the nearest section's that holds it.
pub fn describe<'a>(docs: &'a [ParamDoc], name: &str) -> Option<&'a str> {
    let parts: Vec<&str> = name.split('.').collect();
    let matches = |key: &str| {
        let k: Vec<&str> = key.split('.').collect();
        k.len() <= parts.len() && k.iter().zip(&parts).all(|(a, b)| a == b || *a == "<name>")
    };
    docs.iter()
        .filter(|d| matches(&d.key))
        .max_by_key(|d| d.key.matches('.').count())
        .map(|d| d.description.as_str())
}

/// The leaves under `node` (resolving `$ref`s in `root`), pushed to `out`
/// with keys under `key` and, where a field has none, `said` as description.
fn leaves(root: &Value, node: &Value, key: &str, said: &str, out: &mut Vec<ParamDoc>) {
    let node = resolve(root, node);
    let join = |k: &str| dotted(key, k);
    if let Some(props) = node.get("properties").and_then(Value::as_object) {
        for (name, field) in props {
            // The field's doc comment, else its type's.
            let field_said = text(field)
                .or_else(|| text(resolve(root, field)))
                .unwrap_or(said);
            leaves(root, field, &join(name), field_said, out);
        }
        return;
    }
    if let Some(map) = node.get("additionalProperties").filter(|v| v.is_object()) {
        leaves(root, map, &join("<name>"), said, out);
        return;
    }
    out.push(ParamDoc {
        key: key.to_string(),
        kind: kind(root, node),
        description: one_line(said),
        range: bounds(node).join(", "),
    });
}

/// Refuses a number in `value` outside the range its field declares, or
/// not finite, naming its key under `key`: the range check of every field
/// that declares one, written once on the field.
pub fn check_ranges<T: Serialize + JsonSchema>(value: &T, key: &str) -> Result<(), ParamsError> {
    let schema = schemars::schema_for!(T);
    let root = schema.as_value();
    let value = serde_json::to_value(value).map_err(|e| ParamsError::Invalid {
        key: key.into(),
        value: e.to_string(),
        expected: "parameters that serialise".into(),
    })?;
    within(root, root, &value, key)
}

/// [`check_ranges`] on `value` against `node`.
fn within(root: &Value, node: &Value, value: &Value, key: &str) -> Result<(), ParamsError> {
    let node = resolve(root, node);
    if let (Some(props), Some(fields)) = (
        node.get("properties").and_then(Value::as_object),
        value.as_object(),
    ) {
        for (name, field) in props {
            if let Some(v) = fields.get(name) {
                within(root, field, v, &dotted(key, name))?;
            }
        }
        return Ok(());
    }
    if let (Some(map), Some(entries)) = (
        node.get("additionalProperties").filter(|v| v.is_object()),
        value.as_object(),
    ) {
        for (name, v) in entries {
            within(root, map, v, &dotted(key, name))?;
        }
        return Ok(());
    }
    let limits = bounds(node);
    if limits.is_empty() {
        return Ok(());
    }
    // serde_json writes a non-finite f64 as null: a null where a number
    // (or a list of them) is due is not finite.
    let numbers: Vec<f64> = match value {
        Value::Array(items) => items
            .iter()
            .map(|v| v.as_f64().unwrap_or(f64::NAN))
            .collect(),
        Value::Null if optional(node) => Vec::new(),
        v => vec![v.as_f64().unwrap_or(f64::NAN)],
    };
    match numbers
        .into_iter()
        .find(|x| !limits.iter().all(|b| holds(b, *x)))
    {
        Some(x) => Err(invalid(
            key,
            x,
            &format!("a finite value {}", limits.join(" and ")),
        )),
        None => Ok(()),
    }
}

/// True when the schema takes null (an `Option`).
fn optional(node: &Value) -> bool {
    let null = Value::from("null");
    match node.get("type") {
        Some(Value::Array(types)) => types.contains(&null),
        _ => (node.get("anyOf").and_then(Value::as_array))
            .is_some_and(|alts| alts.iter().any(|a| a.get("type") == Some(&null))),
    }
}

/// `key.name`, or `name` at the top.
fn dotted(key: &str, name: &str) -> String {
    match key {
        "" => name.to_string(),
        _ => format!("{key}.{name}"),
    }
}

/// The bounds a schema declares, as `> 0`, `<= 60`.
fn bounds(node: &Value) -> Vec<String> {
    [
        ("exclusiveMinimum", ">"),
        ("minimum", ">="),
        ("exclusiveMaximum", "<"),
        ("maximum", "<="),
    ]
    .iter()
    .filter_map(|(word, op)| {
        node.get(*word)
            .and_then(Value::as_f64)
            .map(|b| format!("{op} {b}"))
    })
    .collect()
}

/// True when `x` keeps the bound `b` (`> 0`).
fn holds(b: &str, x: f64) -> bool {
    let Some((op, v)) = b.split_once(' ') else {
        return false;
    };
    let v: f64 = v.parse().unwrap_or(f64::NAN);
    x.is_finite()
        && match op {
            ">" => x > v,
            ">=" => x >= v,
            "<" => x < v,
            _ => x <= v,
        }
}

/// `node`, or what its `$ref` names in `root`'s `$defs`.
fn resolve<'a>(root: &'a Value, node: &'a Value) -> &'a Value {
    match node.get("$ref").and_then(Value::as_str) {
        Some(r) => r
            .strip_prefix("#/$defs/")
            .and_then(|name| root.get("$defs")?.get(name))
            .map_or(node, |target| resolve(root, target)),
        None => node,
    }
}

/// The type of a leaf: its JSON type (an optional one's without null), or
/// a list of its items' type.
fn kind(root: &Value, node: &Value) -> String {
    let node = resolve(root, node);
    let types: Vec<&str> = match node.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).collect(),
        _ => Vec::new(),
    };
    let one = types.iter().find(|t| **t != "null").copied();
    let choices: Vec<&str> = match (node.get("enum"), node.get("oneOf")) {
        (Some(Value::Array(values)), _) => values.iter().filter_map(Value::as_str).collect(),
        (_, Some(Value::Array(alts))) => alts
            .iter()
            .filter_map(|a| a.get("const").and_then(Value::as_str))
            .collect(),
        _ => Vec::new(),
    };
    if !choices.is_empty() {
        return format!("one of {}", choices.join(", "));
    }
    match one {
        Some("array") => match node.get("items") {
            Some(items) => format!("list of {}", kind(root, items)),
            None => "list".into(),
        },
        Some(t) => t.to_string(),
        None => node
            .get("anyOf")
            .and_then(Value::as_array)
            .and_then(|alts| alts.iter().find(|a| a.get("type") != Some(&"null".into())))
            .map_or_else(|| "any".into(), |a| kind(root, a)),
    }
}

/// A schema's description, if it has one.
fn text(node: &Value) -> Option<&str> {
    node.as_object()
        .and_then(|o: &Map<String, Value>| o.get("description"))
        .and_then(Value::as_str)
}

/// A doc comment as one line, its links to items as plain code.
fn one_line(s: &str) -> String {
    let words = s.split_whitespace().collect::<Vec<_>>().join(" ");
    words.replace("[`", "`").replace("`]", "`")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// A finish.
    #[derive(schemars::JsonSchema, serde::Serialize)]
    #[allow(dead_code)]
    #[serde(rename_all = "lowercase")]
    enum Finish {
        /// Shiny.
        Gloss,
        /// Dull.
        Matt,
    }

    /// A part.
    #[derive(schemars::JsonSchema, serde::Serialize)]
    #[allow(dead_code)]
    struct Part {
        /// Its mass (kg).
        #[schemars(extend("exclusiveMinimum" = 0.0))]
        mass_kg: f64,
        /// Where it is (m).
        at_m: [f64; 3],
        /// Its colour, if painted.
        colour: Option<String>,
        /// How it looks; see [`Finish`].
        finish: Finish,
    }

    /// A machine.
    #[derive(schemars::JsonSchema, serde::Serialize)]
    #[allow(dead_code)]
    struct Machine {
        /// How many (count).
        #[schemars(range(min = 1, max = 60))]
        count: u32,
        /// Its main part.
        main: Part,
        /// Its other parts, by name.
        parts: BTreeMap<String, Part>,
    }

    #[test]
    fn every_leaf_has_its_key_type_and_its_doc_comment() {
        let docs = params_of::<Machine>("machine");
        let row = |k: &str| docs.iter().find(|d| d.key == k).unwrap();
        assert_eq!(docs.len(), 9);
        assert_eq!(row("machine.main.finish").kind, "one of gloss, matt");
        assert_eq!(
            row("machine.main.finish").description,
            "How it looks; see `Finish`."
        );
        assert_eq!(row("machine.count").kind, "integer");
        assert_eq!(row("machine.main.mass_kg").description, "Its mass (kg).");
        assert_eq!(row("machine.main.at_m").kind, "list of number");
        assert_eq!(row("machine.parts.<name>.colour").kind, "string");
        assert_eq!(
            describe(&docs, "machine.parts.wheel.mass_kg"),
            Some("Its mass (kg).")
        );
        assert_eq!(describe(&docs, "machine.main"), None);
        assert_eq!(describe(&docs, "other"), None);
        assert_eq!(row("machine.count").range, ">= 1, <= 60");
        assert_eq!(row("machine.main.mass_kg").range, "> 0");
        assert_eq!(row("machine.main.at_m").range, "");
    }

    #[test]
    fn a_value_outside_its_fields_range_is_refused_by_its_key() {
        let part = |mass_kg| Part {
            mass_kg,
            at_m: [0.0; 3],
            colour: None,
            finish: Finish::Gloss,
        };
        let machine = |count, mass_kg: f64| Machine {
            count,
            main: part(1.0),
            parts: BTreeMap::from([("wheel".to_string(), part(mass_kg))]),
        };
        assert!(check_ranges(&machine(3, 0.5), "m").is_ok());
        let said = |m: Machine| check_ranges(&m, "m").unwrap_err().to_string();
        let e = said(machine(61, 0.5));
        assert!(
            e.contains("m.count") && e.contains("a finite value >= 1 and <= 60"),
            "{e}"
        );
        let e = said(machine(3, 0.0));
        assert!(
            e.contains("m.parts.wheel.mass_kg") && e.contains("> 0"),
            "{e}"
        );
        let e = said(machine(3, f64::NAN));
        assert!(e.contains("m.parts.wheel.mass_kg"), "{e}");
    }
}
