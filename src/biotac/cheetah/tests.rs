use super::*;

#[test]
fn adapters_are_named_by_port_or_serial_number() {
    assert_eq!("0".parse::<AdapterId>(), Ok(AdapterId::Port(0)));
    assert_eq!(" 12 ".parse::<AdapterId>(), Ok(AdapterId::Port(12)));
    assert_eq!(
        "1364-123456".parse::<AdapterId>(),
        Ok(AdapterId::Serial(1_364_123_456))
    );
    assert_eq!(
        "1364123456".parse::<AdapterId>(),
        Ok(AdapterId::Serial(1_364_123_456))
    );
    for bad in ["", "-", "port0", "1.5", "99999999999"] {
        assert!(bad.parse::<AdapterId>().is_err(), "{bad}");
    }
    assert_eq!(
        AdapterId::Serial(1_364_000_042).to_string(),
        "serial 1364-000042"
    );
}

#[test]
fn a_missing_library_says_what_to_put_where() {
    let dir = std::env::temp_dir().join(format!("cheetah-missing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let err = ffi::locate(Some(&dir)).unwrap_err();
    let text = err.to_string();
    assert!(text.contains("cheetah.so"), "{text}");
    assert!(text.contains("libcheetah.so"), "{text}");
    assert!(text.contains("LD_LIBRARY_PATH"), "{text}");
    assert!(text.contains("--cheetah-lib"), "{text}");
    assert!(text.contains("cheetah_library"), "{text}");
    assert_eq!(err.class(), ExitClass::Refused);
    assert!(matches!(LinkError::from(err), LinkError::Fatal(_)));
    // A file in the directory is found; a file given is taken as is.
    std::fs::write(dir.join("libcheetah.so"), b"").unwrap();
    assert_eq!(ffi::locate(Some(&dir)).unwrap(), dir.join("libcheetah.so"));
    let file = dir.join("elsewhere.so");
    assert_eq!(ffi::candidates(Some(&file)), vec![file]);
    // Not a library: refused, with the file's name.
    let err = CheetahLib::load(&dir.join("libcheetah.so")).err().unwrap();
    assert!(err.to_string().contains("libcheetah.so"), "{err}");
    assert!(err.fatal());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_search_covers_ld_library_path_and_the_current_directory() {
    let all = ffi::candidates(None);
    let cwd = std::env::current_dir().unwrap();
    assert!(all.contains(&cwd.join("cheetah.so")));
    assert!(all.contains(&cwd.join("libcheetah.so")));
}

#[test]
fn run_time_adapter_errors_are_retried() {
    let busy = CheetahError::Busy(AdapterId::Port(0));
    assert!(!busy.fatal());
    assert!(matches!(LinkError::from(busy), LinkError::Lost(_)));
    assert!(CheetahError::Electrodes(20).fatal());
}
