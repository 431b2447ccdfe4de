//! A node's status, as `/diagnostics` carries it, without the transport:
//! a level, a message and named figures.

/// How a node is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// All is well.
    Ok,
    /// Working, with something to look at.
    Warn,
    /// Not working.
    Error,
}

/// One status report.
#[derive(Debug, Clone, PartialEq)]
pub struct Status {
    /// How it is doing.
    pub level: Level,
    /// One line for people.
    pub message: String,
    /// The figures, by name.
    pub values: Vec<(String, String)>,
}

impl Status {
    /// An Ok status saying `message`, with no figures yet.
    pub fn ok(message: impl Into<String>) -> Self {
        Status {
            level: Level::Ok,
            message: message.into(),
            values: Vec::new(),
        }
    }

    /// Raises the level to `level` (never lowers it) and appends `why` to
    /// the message.
    pub fn raise(&mut self, level: Level, why: &str) {
        self.level = self.level.max(level);
        self.message = format!("{}{why}", self.message);
    }

    /// Adds a figure.
    pub fn value(&mut self, name: &str, value: impl ToString) {
        self.push(name.to_string(), value.to_string());
    }

    /// Adds a figure whose name is made at run time.
    pub fn push(&mut self, name: String, value: String) {
        self.values.push((name, value));
    }
}
