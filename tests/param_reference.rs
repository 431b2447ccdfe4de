//! docs/parameters.md is what the structs that read the parameters say:
//! a field added, renamed or described anew changes it, and this test
//! fails until it is written again (`TACTILE_FORCE_WRITE_DOCS=1`).

use tactile_force::nodes::param_reference::{markdown, RosNode};
use tactile_force::nodes::tasks;

const PAGE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/parameters.md");

#[test]
fn the_parameter_reference_is_current() {
    let page = markdown(&tasks::shipped()).unwrap();
    if std::env::var_os("TACTILE_FORCE_WRITE_DOCS").is_some() {
        std::fs::write(PAGE, &page).unwrap();
    }
    let written = std::fs::read_to_string(PAGE).unwrap_or_default();
    assert!(
        written == page,
        "docs/parameters.md is stale: TACTILE_FORCE_WRITE_DOCS=1 cargo test --release --test \
         param_reference writes it again"
    );
}

#[test]
fn every_shipped_parameter_is_described_by_its_field() {
    let shipped = tasks::shipped();
    for node in RosNode::ALL {
        let docs = node.params(&shipped);
        for (key, _) in node.defaults().unwrap() {
            let said = node.describe(&shipped, &key);
            assert!(
                said != "See the config/ files." && !said.is_empty(),
                "{}: {key} has no description",
                node.name()
            );
        }
        assert!(docs.iter().all(|d| !d.description.is_empty()));
    }
    // The adapters' own: listed, each described, none read from the files.
    let page = markdown(&shipped).unwrap();
    for node in RosNode::ALL {
        for (doc, default) in node.own() {
            let row = format!("| `{}` | {} |  | {default} | ", doc.key, doc.kind);
            assert!(page.contains(&row), "{row}");
            assert!(!node.params(&shipped).iter().any(|d| d.key == doc.key));
        }
    }
    let said = RosNode::ForceController.describe(&shipped, "guided.deadband_n");
    assert_eq!(said, "Deadband on the force error (N).");
    let said = RosNode::SimRobot.describe(&shipped, "objects.fingertip.friction");
    assert_eq!(said, "Coulomb friction coefficient against the skin.");
}
