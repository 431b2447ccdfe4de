//! The bag header's checks before the `rosbag` crate slices by it.

use super::*;

/// A header record with `index_pos` and 8 bytes of padding.
fn header(index_pos: u64) -> Vec<u8> {
    let field = |name: &str, value: &[u8]| {
        let mut f = ((name.len() + 1 + value.len()) as u32)
            .to_le_bytes()
            .to_vec();
        f.extend(name.as_bytes());
        f.push(b'=');
        f.extend(value);
        f
    };
    let fields = [
        field("op", &[3]),
        field("index_pos", &index_pos.to_le_bytes()),
    ]
    .concat();
    let mut b = ROS1_MAGIC.to_vec();
    b.extend((fields.len() as u32).to_le_bytes());
    b.extend(fields);
    b.extend(8u32.to_le_bytes());
    b.extend([b' '; 8]);
    b
}

fn broken(e: Result<(), HeaderError>) -> String {
    match e {
        Err(HeaderError::Broken(s)) => s,
        Err(HeaderError::NotABag(s)) => panic!("not a bag: {s}"),
        Ok(()) => panic!("accepted"),
    }
}

#[test]
fn the_index_position_must_lie_after_the_header_and_within_the_file() {
    let h = header(60);
    let end = h.len() as u64;
    assert!(check_header(&header(end), end + 100).is_ok());
    assert!(broken(check_header(&header(0), 1000)).contains("not closed"));
    assert!(broken(check_header(&header(end + 101), end + 100)).contains("cut short"));
    assert!(broken(check_header(&header(10), end)).contains("inside the header"));
    assert!(broken(check_header(&h[..20], 20)).contains("ends in its header"));
    match check_header(b"PK\x03\x04", 4) {
        Err(HeaderError::NotABag(s)) => assert!(s.contains("\"PK\\u{3}\\u{4}\""), "{s}"),
        _ => panic!("a zip file is not a bag"),
    }
}
