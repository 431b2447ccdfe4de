use super::*;

#[test]
fn a_missing_folder_a_folder_and_a_bad_format_are_refused_by_role_and_path() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("u2.json");
    check_writable(&good, "model file").unwrap();
    assert!(!good.exists(), "the check writes nothing");
    let leftover = std::fs::read_dir(dir.path()).unwrap().count();
    assert_eq!(leftover, 0, "the probe is removed");

    let e = check_writable(Path::new("/nonexistent-dir/u2.json"), "model file").unwrap_err();
    assert_eq!(
        e.to_string(),
        "model file /nonexistent-dir/u2.json: its folder /nonexistent-dir does not exist"
    );
    assert_eq!(e.class(), ExitClass::Refused);

    let e = check_writable(dir.path(), "session").unwrap_err();
    assert!(e.to_string().ends_with(": is a folder"), "{e}");

    let file = dir.path().join("f");
    std::fs::write(&file, "x").unwrap();
    let e = check_writable(&file.join("s.mcap"), "session").unwrap_err();
    assert!(e.to_string().contains("is not a folder"), "{e}");
    check_writable(&file, "session").unwrap();
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x", "not changed");

    let e = check_format(&dir.path().join("calib.svg"), "plot", &["png"]).unwrap_err();
    assert!(
        e.to_string()
            .ends_with("calib.svg: the format .svg is not written (supported: .png)"),
        "{e}"
    );
    let e = check_format(&dir.path().join("calib"), "plot", &["png"]).unwrap_err();
    assert!(e.reason.starts_with("no extension"), "{e}");
    check_format(&dir.path().join("calib.PNG"), "plot", &["png"]).unwrap();
    // A file name alone is in the working folder.
    check_writable(Path::new("Cargo.toml.never-written"), "plot").unwrap();
}

#[test]
fn a_file_written_whole_replaces_the_old_one_and_leaves_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.json");
    write_whole(&path, b"one").unwrap();
    // A hard link to the old file keeps its content: no write in place.
    let old = dir.path().join("old.json");
    std::fs::hard_link(&path, &old).unwrap();
    write_whole(&path, b"two").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"two");
    assert_eq!(std::fs::read(&old).unwrap(), b"one");
    // A symlink at the path is replaced, its target not written.
    let target = dir.path().join("target");
    std::fs::write(&target, "kept").unwrap();
    let link = dir.path().join("link.json");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    write_whole(&link, b"new").unwrap();
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "kept");
    assert!(!std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    let e = write_whole(&dir.path().join("none/m.json"), b"x").unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::NotFound);
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(
        names.len(),
        4,
        "m.json, old.json, target, link.json: {names:?}"
    );
}
