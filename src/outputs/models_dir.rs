//! The folder that a file named at run time must stay in: a calibration
//! goal's model and session, the estimator's `model_file` set while it
//! runs (the `models_dir` parameter of both nodes). A peer on the DDS
//! domain can send goals and set parameters, so such a name is resolved
//! here before anything is read, written or moved: a relative name goes
//! inside the folder; an absolute path elsewhere, a `..`, or a symlink
//! that leads out (of the file or of a folder on its way) is refused, and
//! so is a file to write that exists, unless the caller allows replacing
//! it. Paths given at launch (parameter files, the CLI) do not come here.

use std::io::ErrorKind;
use std::path::{Component, Path, PathBuf};

/// Why a name is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Refusal {
    /// No name at all.
    #[error("no file named")]
    Empty,
    /// A `..` among its parts.
    #[error("`..` is not allowed (names stay inside models_dir {})", .0.display())]
    ParentDir(PathBuf),
    /// An absolute path outside the folder.
    #[error("is outside models_dir {}: give a name inside it", .0.display())]
    Outside(PathBuf),
    /// A symlink, of the file or of a folder on its way, that resolves
    /// outside the folder (to this path).
    #[error("leads out of models_dir through a symlink (to {})", .0.display())]
    SymlinkOut(PathBuf),
    /// A file to write exists.
    #[error("exists (the goal's overwrite: true replaces it)")]
    Exists,
    /// A folder, not a file.
    #[error("is a folder")]
    Folder,
    /// A file to read, or the folder of one to write, is not there.
    #[error("does not exist")]
    Missing,
    /// The file system said no (the message).
    #[error("{0}")]
    Io(String),
}

/// A name refused, with what it was for.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{role} {name:?}: {why}")]
pub struct NameRefused {
    /// What the file is to the node ("model_file", "session_file").
    pub role: &'static str,
    /// The name as it came.
    pub name: String,
    /// Why.
    pub why: Refusal,
}

/// The folder, resolved once (made if missing).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModelsDir {
    /// The folder with every symlink followed.
    root: PathBuf,
    /// The folder as configured, made absolute: a path under it is taken too.
    given: PathBuf,
}

impl ModelsDir {
    /// The folder `dir`, made if it does not exist.
    pub fn new(dir: &Path) -> Result<Self, String> {
        let said = |e: std::io::Error| format!("models_dir {}: {e}", dir.display());
        std::fs::create_dir_all(dir).map_err(said)?;
        Ok(ModelsDir {
            root: dir.canonicalize().map_err(said)?,
            given: std::path::absolute(dir).map_err(said)?,
        })
    }

    /// The folder, resolved.
    pub fn path(&self) -> &Path {
        &self.root
    }

    /// Where a new file named `name` (its `role`) is to be written: inside
    /// the folder, through no symlink leading out, its folder there; a
    /// file that exists is refused unless `overwrite` (it is then replaced
    /// by a rename, never written through).
    pub fn output(
        &self,
        role: &'static str,
        name: &str,
        overwrite: bool,
    ) -> Result<PathBuf, NameRefused> {
        let refuse = |why| NameRefused {
            role,
            name: name.into(),
            why,
        };
        let path = self.inside(name).map_err(refuse)?;
        let (Some(parent), Some(file)) = (path.parent(), path.file_name()) else {
            return Err(refuse(Refusal::Folder));
        };
        if path == self.root {
            return Err(refuse(Refusal::Folder));
        }
        let parent = self.resolved(parent).map_err(refuse)?;
        let path = parent.join(file);
        match std::fs::symlink_metadata(&path) {
            Err(e) if e.kind() == ErrorKind::NotFound => Ok(path),
            Err(e) => Err(refuse(Refusal::Io(e.to_string()))),
            Ok(m) if m.file_type().is_symlink() => {
                let target = link_target(&path);
                if !target.starts_with(&self.root) {
                    Err(refuse(Refusal::SymlinkOut(target)))
                } else if overwrite {
                    Ok(path)
                } else {
                    Err(refuse(Refusal::Exists))
                }
            }
            Ok(m) if m.is_dir() => Err(refuse(Refusal::Folder)),
            Ok(_) if overwrite => Ok(path),
            Ok(_) => Err(refuse(Refusal::Exists)),
        }
    }

    /// The file named `name` (its `role`) to read: it exists and, every
    /// symlink followed, is inside the folder. The resolved path.
    pub fn input(&self, role: &'static str, name: &str) -> Result<PathBuf, NameRefused> {
        let refuse = |why| NameRefused {
            role,
            name: name.into(),
            why,
        };
        let path = self.inside(name).map_err(refuse)?;
        let real = self.resolved(&path).map_err(refuse)?;
        if real.is_dir() {
            return Err(refuse(Refusal::Folder));
        }
        Ok(real)
    }

    /// `name` read as a path in the folder, before any symlink: a relative
    /// name joined to it, an absolute one under it.
    fn inside(&self, name: &str) -> Result<PathBuf, Refusal> {
        if name.is_empty() {
            return Err(Refusal::Empty);
        }
        let p = Path::new(name);
        if p.components().any(|c| c == Component::ParentDir) {
            return Err(Refusal::ParentDir(self.root.clone()));
        }
        if !p.is_absolute() {
            return Ok(self.root.join(p));
        }
        let rest = p
            .strip_prefix(&self.root)
            .or_else(|_| p.strip_prefix(&self.given))
            .map_err(|_| Refusal::Outside(self.root.clone()))?;
        Ok(self.root.join(rest))
    }

    /// `path` with every symlink followed, refused unless inside.
    fn resolved(&self, path: &Path) -> Result<PathBuf, Refusal> {
        let real = path.canonicalize().map_err(|e| match e.kind() {
            ErrorKind::NotFound => Refusal::Missing,
            _ => Refusal::Io(e.to_string()),
        })?;
        if real.starts_with(&self.root) {
            Ok(real)
        } else {
            Err(Refusal::SymlinkOut(real))
        }
    }
}

/// Where the symlink `link` points: resolved, or (dangling) its target as
/// written, taken from the link's folder.
fn link_target(link: &Path) -> PathBuf {
    link.canonicalize().unwrap_or_else(|_| {
        let to = std::fs::read_link(link).unwrap_or_default();
        link.parent().map_or(to.clone(), |dir| dir.join(&to))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::symlink;

    /// A models_dir in a temporary folder, with a folder outside it.
    fn setup() -> (tempfile::TempDir, ModelsDir, PathBuf) {
        let tmp = tempfile::tempdir().unwrap();
        let dir = ModelsDir::new(&tmp.path().join("models")).unwrap();
        let outside = tmp.path().join("outside");
        std::fs::create_dir(&outside).unwrap();
        (tmp, dir, outside)
    }

    fn why(r: Result<PathBuf, NameRefused>) -> Refusal {
        r.unwrap_err().why
    }

    #[test]
    fn a_relative_name_or_an_absolute_path_inside_is_taken() {
        let (_tmp, dir, _) = setup();
        assert!(dir.path().is_dir(), "made");
        let p = dir.output("model_file", "u2.json", false).unwrap();
        assert_eq!(p, dir.path().join("u2.json"));
        let abs = dir.path().join("u3.json");
        let same = dir.output("model_file", abs.to_str().unwrap(), false);
        assert_eq!(same.unwrap(), abs);
        std::fs::create_dir(dir.path().join("unit2")).unwrap();
        let sub = dir.output("session_file", "unit2/./s.mcap", false).unwrap();
        assert_eq!(sub, dir.path().join("unit2/s.mcap"));
        assert!(
            std::fs::read_dir(dir.path()).unwrap().count() == 1,
            "nothing written"
        );
    }

    #[test]
    fn outside_paths_and_parent_dirs_are_refused_with_the_reason() {
        let (_tmp, dir, outside) = setup();
        let name = outside.join("x.json");
        let e = dir
            .output("model_file", name.to_str().unwrap(), true)
            .unwrap_err();
        assert_eq!(e.why, Refusal::Outside(dir.path().into()));
        assert!(e.to_string().contains("is outside models_dir"), "{e}");
        for name in ["../x.json", "a/../../x.json", "a/.."] {
            let r = dir.output("model_file", name, true);
            assert!(matches!(why(r), Refusal::ParentDir(_)), "{name}");
        }
        let inner = format!("{}/../outside/x.json", dir.path().display());
        assert!(matches!(
            why(dir.output("model_file", &inner, true)),
            Refusal::ParentDir(_)
        ));
        assert_eq!(why(dir.output("model_file", "", true)), Refusal::Empty);
        assert_eq!(why(dir.input("model_file", "/etc/hostname")), {
            Refusal::Outside(dir.path().into())
        });
        assert!(!outside.join("x.json").exists());
    }

    #[test]
    fn symlinks_leading_out_are_refused_and_inside_ones_taken() {
        let (_tmp, dir, outside) = setup();
        std::fs::write(outside.join("secret.json"), "{}").unwrap();
        symlink(outside.join("secret.json"), dir.path().join("link.json")).unwrap();
        symlink(&outside, dir.path().join("out")).unwrap();
        symlink(outside.join("none.json"), dir.path().join("dangling.json")).unwrap();
        for name in ["link.json", "out/new.json", "dangling.json"] {
            let r = dir.output("model_file", name, true);
            assert!(matches!(why(r), Refusal::SymlinkOut(_)), "{name}");
        }
        for name in ["link.json", "out/secret.json"] {
            let r = dir.input("model_file", name);
            assert!(matches!(why(r), Refusal::SymlinkOut(_)), "{name}");
        }
        // A link within the folder is a file like any other.
        std::fs::write(dir.path().join("a.json"), "{}").unwrap();
        symlink(dir.path().join("a.json"), dir.path().join("b.json")).unwrap();
        assert_eq!(
            dir.input("model_file", "b.json").unwrap(),
            dir.path().join("a.json")
        );
        assert_eq!(
            why(dir.output("model_file", "b.json", false)),
            Refusal::Exists
        );
    }

    #[test]
    fn an_existing_file_is_replaced_only_when_asked_and_a_missing_one_not_read() {
        let (_tmp, dir, _) = setup();
        std::fs::write(dir.path().join("u2.json"), "old").unwrap();
        let e = dir.output("model_file", "u2.json", false).unwrap_err();
        assert_eq!(e.why, Refusal::Exists);
        assert!(e.to_string().contains("overwrite: true"), "{e}");
        let p = dir.output("model_file", "u2.json", true).unwrap();
        assert_eq!(p, dir.path().join("u2.json"));
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old", "not touched");
        assert_eq!(dir.input("model_file", "u2.json").unwrap(), p);
        assert_eq!(why(dir.input("model_file", "u9.json")), Refusal::Missing);
        assert_eq!(why(dir.output("s", "nofolder/x", true)), Refusal::Missing);
        std::fs::create_dir(dir.path().join("d")).unwrap();
        assert_eq!(why(dir.output("s", "d", true)), Refusal::Folder);
        assert_eq!(why(dir.input("s", "d")), Refusal::Folder);
        assert_eq!(why(dir.output("s", ".", true)), Refusal::Folder);
    }

    #[test]
    fn a_folder_given_through_a_symlink_takes_paths_under_either_name() {
        let (tmp, real, _) = setup();
        let alias = tmp.path().join("alias");
        symlink(real.path(), &alias).unwrap();
        let dir = ModelsDir::new(&alias).unwrap();
        assert_eq!(dir.path(), real.path());
        let name = alias.join("u2.json");
        let p = dir.output("model_file", name.to_str().unwrap(), false);
        assert_eq!(p.unwrap(), real.path().join("u2.json"));
    }
}
