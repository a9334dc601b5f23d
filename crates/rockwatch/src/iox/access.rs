//! Who can reach this deployment's iceoryx2 resources: the checks every rockwatch endpoint
//! runs around the creation of its iceoryx2 node, so that another user of the host can neither
//! publish on its services nor break node creation.
//!
//! iceoryx2 0.10.0 keeps two kinds of resources (docs/iceoryx2.md, "Who can reach it"):
//! - files under `[global] root-path` (node and service directories, sockets): the root
//!   directory must be a directory of this user that no one else can write; it is created
//!   with mode 0700 when missing. Checked by [`check_root_dir`], with its ancestors.
//! - POSIX shared memory in `/dev/shm`, named `<[global] prefix>…` (the root path does not
//!   move them). Every segment of them is owner-only (0600) except the global management
//!   segment `<prefix><hash>_node.0_10_0.global_mgmt`, which iceoryx2 creates readable and
//!   writable by everyone (`enable_global_access(true)`): another user could overwrite its
//!   version word and every later node creation would fail (`UnableToGenerateUniqueNodeId`).
//!   [`check_segments`] refuses any segment with the prefix that belongs to another user (a
//!   squatted name), [`restrict_management_segment`] restricts the management segment of
//!   this user to 0600, before the node is created and right after.
//!
//! What no permission can protect: every process of the same user (or root) can open,
//! publish on and corrupt every service.

use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

use iceoryx2::config::Config;
use iceoryx2::prelude::*;

/// Where Linux keeps POSIX shared memory (`shm_open` names).
pub const SHM_DIR: &str = "/dev/shm";

/// What precedes `[global.node] global-mgmt-suffix` in the management segment's name:
/// `_<name "node">.<iceoryx2 major>_<minor>_<patch>` (iceoryx2 0.10.0,
/// `node/global_management_segment.rs`; the crate is pinned to `=0.10.0`).
const GLOBAL_MGMT_MARK: &str = "_node.0_10_0";

/// Mode bits no one but the owner may have on the root directory: group and other write.
const FOREIGN_WRITE: u32 = 0o022;

/// The iceoryx2 resources of one configuration, as this process sees them.
#[derive(Debug, Clone)]
pub struct Deployment {
    /// `[global] root-path`.
    pub root_dir: PathBuf,
    /// `[global] prefix` of the shared-memory segments.
    pub prefix: String,
    /// `[global.node] global-mgmt-suffix`.
    pub global_mgmt_suffix: String,
    /// The directory holding the segments ([`SHM_DIR`]; another one in unit tests).
    pub shm_dir: PathBuf,
}

impl Deployment {
    /// The resources of `config`.
    pub fn of(config: &Config) -> Deployment {
        let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
        Deployment {
            root_dir: PathBuf::from(std::ffi::OsStr::from_bytes(
                config.global.root_path().as_bytes(),
            )),
            prefix: text(config.global.prefix.as_bytes()),
            global_mgmt_suffix: text(config.global.node.global_mgmt_suffix.as_bytes()),
            shm_dir: PathBuf::from(SHM_DIR),
        }
    }

    /// Whether `name` (a file of [`Deployment::shm_dir`]) is the global management segment.
    fn is_management_segment(&self, name: &str) -> bool {
        name.starts_with(&self.prefix)
            && name
                .strip_suffix(self.global_mgmt_suffix.as_str())
                .is_some_and(|rest| rest.ends_with(GLOBAL_MGMT_MARK))
    }

    /// Everything to check before creating a node for user `uid`: the root directory (created
    /// with mode 0700 when missing) and the segments with the prefix; restricts this user's
    /// management segment to 0600. The error is one sentence naming the path and the fix.
    pub fn check_before_node(&self, uid: u32) -> Result<(), AccessError> {
        check_root_dir(&self.root_dir, uid)?;
        check_segments(self, uid)?;
        restrict_management_segment(self)?;
        Ok(())
    }
}

/// Why iceoryx2's files are not safe to use for this user (or could not be checked): one sentence naming the path and the fix.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct AccessError(pub String);

impl From<String> for AccessError {
    fn from(reason: String) -> Self {
        AccessError(reason)
    }
}

impl From<&str> for AccessError {
    fn from(reason: &str) -> Self {
        AccessError(reason.to_owned())
    }
}

/// The effective user id of this process (the `Uid:` line of `/proc/self/status`: real,
/// effective, saved, file-system), which owns the files it creates.
pub fn effective_uid() -> Result<u32, AccessError> {
    let status = std::fs::read_to_string("/proc/self/status")
        .map_err(|e| format!("/proc/self/status: {e} (needed to check iceoryx2's permissions)"))?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("Uid:"))
        .and_then(|ids| ids.split_whitespace().nth(1))
        .and_then(|euid| euid.parse().ok())
        .ok_or_else(|| AccessError::from("/proc/self/status: no effective uid"))
}

/// Checks (or creates, mode 0700) the iceoryx2 root directory: a real directory (not a
/// symbolic link) owned by `uid`, not writable by group or others, whose ancestors only
/// `uid` or root can replace it in (owned by one of them, and not writable by others unless
/// sticky, like `/tmp`).
pub fn check_root_dir(root: &Path, uid: u32) -> Result<(), AccessError> {
    let shown = root.display();
    if !root.is_absolute() {
        return Err(AccessError::from(format!(
            "iceoryx2 root-path {shown} is not absolute: set [global] root-path to an absolute directory"
        )));
    }
    for ancestor in root.ancestors().skip(1) {
        check_ancestor(ancestor, root, uid)?;
    }
    match std::fs::DirBuilder::new().mode(0o700).create(root) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        Err(e) => {
            return Err(AccessError::from(format!(
                "iceoryx2 root-path {shown}: cannot create it: {e} (create its parent, or set [global] root-path to a directory of this user)"
            )))
        }
    }
    let meta =
        std::fs::symlink_metadata(root).map_err(|e| format!("iceoryx2 root-path {shown}: {e}"))?;
    let fix = "remove it, or set [global] root-path to a directory of this user with mode 0700";
    if meta.file_type().is_symlink() {
        return Err(AccessError::from(format!(
            "iceoryx2 root-path {shown} is a symbolic link, which another user may have planted: {fix}"
        )));
    }
    if !meta.is_dir() {
        return Err(AccessError::from(format!(
            "iceoryx2 root-path {shown} is not a directory: {fix}"
        )));
    }
    if meta.uid() != uid {
        return Err(AccessError::from(format!(
            "iceoryx2 root-path {shown} belongs to uid {}, not to this user (uid {uid}): that user could publish on this node's services or replace them; {fix}",
            meta.uid()
        )));
    }
    let mode = meta.mode() & 0o7777;
    if mode & FOREIGN_WRITE != 0 {
        return Err(AccessError::from(format!(
            "iceoryx2 root-path {shown} has mode {mode:04o}, writable by other users, who could replace this node's services: chmod 700 it, or {fix}"
        )));
    }
    Ok(())
}

/// An ancestor of the root directory: owned by `uid` or root, and not writable by others
/// unless sticky (where only a file's owner can rename or remove it).
fn check_ancestor(dir: &Path, root: &Path, uid: u32) -> Result<(), String> {
    let meta = match std::fs::metadata(dir) {
        Ok(m) => m,
        // A missing ancestor: creating the root directory will fail with its own message.
        Err(_) => return Ok(()),
    };
    let mode = meta.mode() & 0o7777;
    let sticky = mode & 0o1000 != 0;
    if meta.uid() != uid && meta.uid() != 0 {
        return Err(format!(
            "iceoryx2 root-path {}: its parent {} belongs to uid {}, who could replace it; set [global] root-path to a directory of this user",
            root.display(),
            dir.display(),
            meta.uid()
        ));
    }
    if mode & FOREIGN_WRITE != 0 && !sticky {
        return Err(format!(
            "iceoryx2 root-path {}: its parent {} has mode {mode:04o}, writable by other users, who could replace it; set [global] root-path to a directory of this user",
            root.display(),
            dir.display()
        ));
    }
    Ok(())
}

/// Refuses any shared-memory segment with the deployment's prefix that is not a regular file
/// of `uid`: another user who creates a name of this deployment first (a squatted name) would
/// own the segment this node uses, or make its creation fail with an obscure iceoryx2 error.
pub fn check_segments(deployment: &Deployment, uid: u32) -> Result<(), AccessError> {
    let dir = &deployment.shm_dir;
    let entries = std::fs::read_dir(dir)
        .map_err(|e| format!("iceoryx2 shared memory {}: {e}", dir.display()))?;
    for entry in entries.flatten() {
        let name = entry.file_name();
        if !name.as_bytes().starts_with(deployment.prefix.as_bytes()) {
            continue;
        }
        let path = entry.path();
        let Ok(meta) = std::fs::symlink_metadata(&path) else {
            continue; // removed meanwhile (a node of this user going away)
        };
        let fix = format!(
            "another user holds a name of this deployment's iceoryx2 prefix {:?}: remove it (as root) or set another [global] prefix",
            deployment.prefix
        );
        if meta.uid() != uid {
            return Err(AccessError::from(format!(
                "iceoryx2 shared memory {} belongs to uid {}, not to this user (uid {uid}); {fix}",
                path.display(),
                meta.uid()
            )));
        }
        if !meta.is_file() {
            return Err(AccessError::from(format!(
                "iceoryx2 shared memory {} is not a regular file; {fix}",
                path.display()
            )));
        }
    }
    Ok(())
}

/// The global management segments of the deployment in its shared-memory directory (one,
/// once a node was created; none if the directory cannot be read).
pub fn management_segments(deployment: &Deployment) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(&deployment.shm_dir) else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter(|e| deployment.is_management_segment(&e.file_name().to_string_lossy()))
        .map(|e| e.path())
        .collect()
}

/// Restricts this user's global management segment (if it exists) to mode 0600: iceoryx2
/// creates it readable and writable by everyone. Returns the segments restricted.
pub fn restrict_management_segment(deployment: &Deployment) -> Result<Vec<PathBuf>, AccessError> {
    let mut restricted = Vec::new();
    for path in management_segments(deployment) {
        let Ok(meta) = std::fs::symlink_metadata(&path) else {
            continue;
        };
        if !meta.is_file() || meta.mode() & 0o077 == 0 {
            continue;
        }
        // A file of another user was refused by `check_segments`; chmod fails on one created
        // since, and that is reported.
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).map_err(|e| {
            format!(
                "iceoryx2 management segment {}: cannot restrict it to mode 0600: {e}; remove it (as root) or set another [global] prefix",
                path.display()
            )
        })?;
        restricted.push(path);
    }
    Ok(restricted)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deployment(shm: &Path, root: &Path) -> Deployment {
        Deployment {
            root_dir: root.to_path_buf(),
            prefix: "rwtest_".into(),
            global_mgmt_suffix: ".global_mgmt".into(),
            shm_dir: shm.to_path_buf(),
        }
    }

    fn mode(path: &Path) -> u32 {
        std::fs::symlink_metadata(path).unwrap().mode() & 0o7777
    }

    #[test]
    fn a_missing_root_directory_is_created_private() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("iox");
        check_root_dir(&root, effective_uid().unwrap()).unwrap();
        assert_eq!(mode(&root), 0o700);
        // And accepted as it is on the next start.
        check_root_dir(&root, effective_uid().unwrap()).unwrap();
    }

    #[test]
    fn a_writable_root_directory_a_link_or_a_file_is_refused_with_one_line() {
        let dir = tempfile::tempdir().unwrap();
        let uid = effective_uid().unwrap();
        let root = dir.path().join("iox");
        std::fs::create_dir(&root).unwrap();
        for m in [0o777, 0o720, 0o702] {
            std::fs::set_permissions(&root, std::fs::Permissions::from_mode(m)).unwrap();
            let e = check_root_dir(&root, uid).unwrap_err().to_string();
            assert!(
                e.contains("writable by other users") && !e.contains('\n'),
                "{e}"
            );
        }
        // Readable by the group is allowed (iceoryx2 itself creates 0750).
        std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o750)).unwrap();
        check_root_dir(&root, uid).unwrap();
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(&root, &link).unwrap();
        assert!(check_root_dir(&link, uid)
            .unwrap_err()
            .to_string()
            .contains("symbolic link"));
        let file = dir.path().join("file");
        std::fs::write(&file, "").unwrap();
        assert!(check_root_dir(&file, uid)
            .unwrap_err()
            .to_string()
            .contains("not a directory"));
        assert!(check_root_dir(Path::new("relative/iox"), uid)
            .unwrap_err()
            .to_string()
            .contains("not absolute"));
    }

    #[test]
    fn a_root_directory_of_another_user_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("iox");
        std::fs::create_dir(&root).unwrap();
        std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o700)).unwrap();
        // Seen as another user: the directory is not theirs (no chown needed).
        // (Refused at the directory itself when this user is root, whose parents every user
        // trusts, else already at its parent, the tempdir of this user.)
        let e = check_root_dir(&root, effective_uid().unwrap() + 1)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("belongs to uid {}", effective_uid().unwrap()))
                && !e.contains('\n'),
            "{e}"
        );
    }

    #[test]
    fn a_parent_writable_by_others_without_the_sticky_bit_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let parent = dir.path().join("open");
        std::fs::create_dir(&parent).unwrap();
        std::fs::set_permissions(&parent, std::fs::Permissions::from_mode(0o777)).unwrap();
        let e = check_root_dir(&parent.join("iox"), effective_uid().unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("its parent") && e.contains("0777"), "{e}");
        // Sticky, like /tmp: accepted.
        std::fs::set_permissions(&parent, std::fs::Permissions::from_mode(0o1777)).unwrap();
        check_root_dir(&parent.join("iox"), effective_uid().unwrap()).unwrap();
    }

    #[test]
    fn the_management_segment_is_restricted_and_foreign_segments_are_refused() {
        let shm = tempfile::tempdir().unwrap();
        let d = deployment(shm.path(), Path::new("/unused"));
        let mgmt = shm
            .path()
            .join("rwtest_9204dd183d1c4d8e1ff592a30766ffa6765aa8b5_node.0_10_0.global_mgmt");
        let other_prefix = shm.path().join("iox2_x_node.0_10_0.global_mgmt");
        let data = shm.path().join("rwtest_abc.data");
        for (path, m) in [(&mgmt, 0o666), (&other_prefix, 0o666), (&data, 0o600)] {
            std::fs::write(path, [0u8; 16]).unwrap();
            std::fs::set_permissions(path, std::fs::Permissions::from_mode(m)).unwrap();
        }
        let uid = effective_uid().unwrap();
        d.check_before_node(uid).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(mode(&mgmt), 0o600);
        // Another deployment's segment is left alone.
        assert_eq!(mode(&other_prefix), 0o666);
        assert_eq!(mode(&data), 0o600);
        // Seen by another user, this user's segments are foreign: refused, naming the file.
        let e = check_segments(&d, uid + 1).unwrap_err().to_string();
        assert!(
            e.contains("belongs to uid") && e.contains("rwtest_") && !e.contains('\n'),
            "{e}"
        );
    }
}
