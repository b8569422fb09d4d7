//! Issue 13, "never destroy what the output path names": an output is
//! renamed into place only over a regular file or a new path; streams are
//! written in place, the rest is refused; a killed run's temporary files are
//! removed by the next run.

use std::io::Read;
use std::path::Path;

use haptex_core::io::{OutputTarget, write_atomic};

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let status = std::process::Command::new("mkfifo").arg(path).status().expect("mkfifo runs");
    assert!(status.success());
}

#[cfg(unix)]
fn is_fifo(path: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_fifo())
}

/// A FIFO given as the output is written through, and is still a FIFO
/// afterwards (it used to be replaced by a regular file).
#[cfg(unix)]
#[test]
fn output_to_a_fifo_is_written_in_place_not_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("f");
    mkfifo(&fifo);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            let mut text = String::new();
            std::fs::File::open(&fifo).unwrap().read_to_string(&mut text).unwrap();
            text
        })
    };
    write_atomic(&fifo, |w| w.write_all(b"x_mm,mu\n0,1\n")).unwrap();
    assert_eq!(reader.join().unwrap(), "x_mm,mu\n0,1\n");
    assert!(is_fifo(&fifo), "the FIFO was replaced");
    // Nothing else appeared beside it.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

/// Character devices and descriptor paths are streams; regular files and
/// new paths are replaced atomically; `-` is standard output. Checked by
/// classification only: a test must not risk the machine's /dev/null.
#[cfg(unix)]
#[test]
fn output_to_a_device_is_a_stream() {
    assert_eq!(OutputTarget::of(Path::new("/dev/null")).unwrap(), OutputTarget::Stream("/dev/null".into()));
    assert_eq!(OutputTarget::of(Path::new("/dev/stdout")).unwrap(), OutputTarget::Stream("/dev/stdout".into()));
    assert_eq!(OutputTarget::of(Path::new("-")).unwrap(), OutputTarget::Stdout);
    let dir = tempfile::tempdir().unwrap();
    let new = dir.path().join("new.csv");
    assert_eq!(OutputTarget::of(&new).unwrap(), OutputTarget::File(new.clone()));
}

/// A directory (or a block device, socket ...) is refused with an error
/// that says what it is, and is left as it was.
#[test]
fn output_to_a_directory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("sub");
    std::fs::create_dir(&target).unwrap();
    let e = write_atomic(&target, |w| w.write_all(b"x")).unwrap_err();
    assert!(e.to_string().contains("is a directory"), "{e}");
    assert!(target.is_dir());
    #[cfg(unix)]
    {
        let socket_path = dir.path().join("s.sock");
        let _socket = std::os::unix::net::UnixListener::bind(&socket_path).unwrap();
        let e = write_atomic(&socket_path, |w| w.write_all(b"x")).unwrap_err();
        assert!(e.to_string().contains("is a socket"), "{e}");
    }
}

/// A symbolic link to a regular file stays a link; its target gets the
/// new content.
#[cfg(unix)]
#[test]
fn output_through_a_symlink_replaces_the_target_and_keeps_the_link() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("real.csv");
    std::fs::write(&target, "old\n").unwrap();
    let link = dir.path().join("link.csv");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    write_atomic(&link, |w| w.write_all(b"new\n")).unwrap();
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "new\n");
}

/// Issue 35: a dangling symbolic link given as the output (a link to a
/// file that does not exist yet) stays a link, and the file it names is
/// created, atomically (the temporary beside the target: nothing is left
/// beside the link): absolute and relative links (relative to the link's
/// own directory, not the working directory), and chains of links. A link
/// whose target's directory does not exist is a clear error, and nothing
/// is created. (It used to replace the link by a regular file.)
#[cfg(unix)]
#[test]
fn output_through_a_dangling_symlink_creates_the_target_and_keeps_the_link() {
    use std::os::unix::fs::symlink;
    let dir = tempfile::tempdir().unwrap();
    let links = dir.path().join("links");
    let data = dir.path().join("data");
    std::fs::create_dir_all(&links).unwrap();
    std::fs::create_dir_all(&data).unwrap();
    let is_link = |p: &Path| std::fs::symlink_metadata(p).unwrap().file_type().is_symlink();

    // Absolute, relative (to the link's directory), and a chain of two.
    symlink(data.join("abs.csv"), links.join("abs")).unwrap();
    symlink("../data/rel.csv", links.join("rel")).unwrap();
    symlink("middle", links.join("chain")).unwrap();
    symlink("../data/end.csv", links.join("middle")).unwrap();
    for (link, target) in [("abs", "abs.csv"), ("rel", "rel.csv"), ("chain", "end.csv")] {
        let link = links.join(link);
        let OutputTarget::File(resolved) = OutputTarget::of(&link).unwrap() else { panic!("{}", link.display()) };
        assert_eq!(resolved.file_name().unwrap(), target);
        assert_eq!(std::fs::canonicalize(resolved.parent().unwrap()).unwrap(), std::fs::canonicalize(&data).unwrap());
        write_atomic(&link, |w| w.write_all(b"x_mm,mu\n0,1\n")).unwrap();
        assert!(is_link(&link), "{}: the link was replaced", link.display());
        assert_eq!(std::fs::read_to_string(data.join(target)).unwrap(), "x_mm,mu\n0,1\n", "{target}");
        // Written again, through the link to the now existing file.
        write_atomic(&link, |w| w.write_all(b"x_mm,mu\n0,2\n")).unwrap();
        assert!(is_link(&link));
        assert_eq!(std::fs::read_to_string(data.join(target)).unwrap(), "x_mm,mu\n0,2\n");
    }
    // The links' directory holds the links only (no temporary, no file).
    let mut names: Vec<String> =
        std::fs::read_dir(&links).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    assert_eq!(names, ["abs", "chain", "middle", "rel"]);

    // A target in a directory that does not exist: an error naming it.
    let missing = links.join("missing");
    symlink(dir.path().join("no-such-dir/out.csv"), &missing).unwrap();
    let e = write_atomic(&missing, |w| w.write_all(b"x")).unwrap_err().to_string();
    assert!(e.contains("no-such-dir/out.csv") && e.contains("its directory does not exist"), "{e}");
    assert!(is_link(&missing) && !dir.path().join("no-such-dir").exists());
    // A loop of links is an error too, not an endless walk.
    symlink("loop-b", links.join("loop-a")).unwrap();
    symlink("loop-a", links.join("loop-b")).unwrap();
    assert!(write_atomic(&links.join("loop-a"), |w| w.write_all(b"x")).is_err());
}

/// Temporary files of processes that no longer run (killed writes) are
/// removed by the next write into their directory; a live process's are
/// kept, and so are those of a process table this process cannot see (the
/// same PID on another node or in another PID namespace sharing the
/// directory: Slurm tasks on a shared scratch directory) and an older
/// haptex's names without one.
#[cfg(target_os = "linux")]
#[test]
fn killed_runs_temporaries_are_cleaned_by_the_next_run() {
    use haptex_core::io::temporary_prefix_of;
    let dir = tempfile::tempdir().unwrap();
    // PIDs above the kernel's largest (4194304) never run.
    let dead = dir.path().join(format!("{}Ab12Cd.tmp", temporary_prefix_of(999_999_999)));
    std::fs::write(&dead, "half").unwrap();
    let dead_dir = dir.path().join(format!("{}Xy34Zw.tmp", temporary_prefix_of(999_999_998)));
    std::fs::create_dir(&dead_dir).unwrap();
    std::fs::write(dead_dir.join("bump.csv"), "half").unwrap();
    let live = dir.path().join(format!("{}Ef56Gh.tmp", temporary_prefix_of(std::process::id())));
    std::fs::write(&live, "mine").unwrap();
    let other_node = dir.path().join(".haptex-999999997-0000beef-Ij78Kl.tmp");
    std::fs::write(&other_node, "another node's write in progress").unwrap();
    let older_haptex = dir.path().join(".haptex-999999996-Mn90Op.tmp");
    std::fs::write(&older_haptex, "kept").unwrap();
    let unrelated = dir.path().join(".haptex-notes.tmp");
    std::fs::write(&unrelated, "a user's file").unwrap();
    assert!(!temporary_prefix_of(1).contains("-0000beef-"), "the test's foreign space is this one");

    write_atomic(&dir.path().join("out.csv"), |w| w.write_all(b"x\n1\n")).unwrap();
    assert!(!dead.exists() && !dead_dir.exists(), "a dead run's temporaries are left");
    assert!(live.exists() && unrelated.exists());
    assert!(other_node.exists(), "another process table's temporary was removed");
    assert!(older_haptex.exists());
}
