//! A model file of any family ([`load`]: the estimator node, `demo
//! --model` and `eval --model` take any) and the id an estimate names it
//! by.

use std::path::Path;

use sha2::Digest;

pub use super::families::load;

/// Which model an estimate came from: its file and the start of the
/// file's SHA-256 (`sha256sum FILE | cut -c1-16`), so that a consumer
/// tells two versions of one file name apart.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ModelId {
    /// The file's path; empty for a model kept in no file.
    pub file: String,
    /// 16 hex digits; empty when there is no file or it cannot be read.
    pub sha256: String,
}

impl ModelId {
    /// The id of the model in `file` (None: a model in no file).
    pub fn of(file: Option<&Path>) -> ModelId {
        let Some(path) = file else {
            return ModelId::default();
        };
        let sha256 = std::fs::read(path).map_or_else(
            |_| String::new(),
            |bytes| {
                let digest = sha2::Sha256::digest(&bytes);
                digest[..8].iter().map(|b| format!("{b:02x}")).collect()
            },
        );
        ModelId {
            file: path.display().to_string(),
            sha256,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_model_id_is_its_file_and_the_start_of_its_sha256() {
        let dir = std::env::temp_dir().join(format!("tf_model_id_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.json");
        std::fs::write(&path, b"abc").unwrap();
        // SHA-256("abc"), FIPS 180-2 appendix B.1: ba7816bf8f01cfea...
        let id = ModelId::of(Some(&path));
        assert_eq!(
            (id.file.as_str(), id.sha256.as_str()),
            (path.to_str().unwrap(), "ba7816bf8f01cfea")
        );
        std::fs::write(&path, b"abd").unwrap();
        assert_ne!(ModelId::of(Some(&path)).sha256, id.sha256);
        assert_eq!(ModelId::of(None), ModelId::default());
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(
            ModelId::of(Some(&path)).sha256,
            "",
            "an unreadable file has no hash"
        );
    }
}
