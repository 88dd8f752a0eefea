//! Atomic output: files and dataset folders appear whole or not at all.

use std::fs;
use std::io::Write;
use std::path::Path;

use fringe3d::io::atomic::{AtomicDir, AtomicError, AtomicFile, write_atomic};

/// A fresh, empty scratch folder for one test.
fn scratch(name: &str) -> crate::cli_support::Tmp {
    crate::cli_support::Tmp::new(&format!("formats-atomic-{name}"))
}

/// Names in a folder, sorted.
fn listing(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn write_atomic_writes_whole_file_and_leaves_no_temp() {
    let d = scratch("whole");
    let p = d.join("out.txt");
    write_atomic(&p, |w| {
        w.write_all(b"hello ")?;
        w.write_all(b"world\n")
    })
    .unwrap();
    assert_eq!(fs::read(&p).unwrap(), b"hello world\n");
    assert_eq!(listing(&d), ["out.txt"]);
    // Replacing an existing file.
    write_atomic(&p, |w| w.write_all(b"second")).unwrap();
    assert_eq!(fs::read(&p).unwrap(), b"second");
    assert_eq!(listing(&d), ["out.txt"]);
}

#[test]
fn failing_writer_leaves_target_untouched() {
    let d = scratch("fail");
    let p = d.join("keep.txt");
    fs::write(&p, b"old content").unwrap();
    let err = write_atomic(&p, |w| {
        w.write_all(b"partial new content")?;
        Err(std::io::Error::other("disk on fire"))
    })
    .unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("keep.txt") && msg.contains("disk on fire"),
        "{msg}"
    );
    assert_eq!(fs::read(&p).unwrap(), b"old content");
    assert_eq!(listing(&d), ["keep.txt"]);
}

#[test]
fn panicking_writer_leaves_target_untouched() {
    let d = scratch("panic");
    let p = d.join("keep.txt");
    fs::write(&p, b"old").unwrap();
    let r = std::panic::catch_unwind(|| {
        let _ = write_atomic(&p, |w| {
            w.write_all(b"new").unwrap();
            panic!("writer panicked");
        });
    });
    assert!(r.is_err());
    assert_eq!(fs::read(&p).unwrap(), b"old");
    assert_eq!(listing(&d), ["keep.txt"]);
}

#[test]
fn bad_targets_are_refused_clearly() {
    let d = scratch("bad");
    let e = write_atomic(Path::new("/"), |_| Ok(())).unwrap_err();
    assert!(matches!(e, AtomicError::BadPath { .. }), "{e}");
    let e = write_atomic(&d, |_| Ok(())).unwrap_err();
    assert!(e.to_string().contains("not a file"), "{e}");
    let missing = d.join("no-such-folder").join("x.txt");
    let e = write_atomic(&missing, |_| Ok(())).unwrap_err();
    assert!(e.to_string().contains("no-such-folder"), "{e}");
    assert_eq!(listing(&d), Vec::<String>::new());
}

#[test]
fn atomic_file_handle_commits_or_vanishes() {
    let d = scratch("handle");
    let p = d.join("a.bin");
    {
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"abc").unwrap();
        assert!(f.temp_path().exists());
        assert!(!p.exists(), "nothing at the target before commit");
        // dropped uncommitted
    }
    assert_eq!(listing(&d), Vec::<String>::new());
    let mut f = AtomicFile::create(&p).unwrap();
    f.write_all(b"abc").unwrap();
    f.commit().unwrap();
    assert_eq!(fs::read(&p).unwrap(), b"abc");
    assert_eq!(listing(&d), ["a.bin"]);
}

#[test]
fn atomic_dir_commit_and_drop() {
    let d = scratch("dir");
    let target = d.join("nested").join("dataset");
    {
        let ad = AtomicDir::create(&target, false).unwrap();
        fs::write(ad.join("f0.png"), b"x").unwrap();
        assert!(!target.exists());
        // dropped uncommitted
    }
    assert!(!target.exists());
    assert_eq!(listing(&d.join("nested")), Vec::<String>::new());

    let ad = AtomicDir::create(&target, false).unwrap();
    fs::create_dir(ad.join("sub")).unwrap();
    fs::write(ad.join("f0.png"), b"x").unwrap();
    fs::write(ad.join("sub").join("f1.png"), b"y").unwrap();
    assert_eq!(ad.commit().unwrap(), target);
    assert_eq!(listing(&target), ["f0.png", "sub"]);
    assert_eq!(fs::read(target.join("sub").join("f1.png")).unwrap(), b"y");
    assert_eq!(listing(&d.join("nested")), ["dataset"]);
}

#[test]
fn atomic_dir_refuses_non_empty_target_unless_overwrite() {
    let d = scratch("dir-exists");
    let target = d.join("ds");
    fs::create_dir(&target).unwrap();
    fs::write(target.join("old.txt"), b"old").unwrap();

    let e = AtomicDir::create(&target, false).unwrap_err();
    assert!(matches!(e, AtomicError::NotEmpty { .. }), "{e}");
    assert!(
        e.to_string().contains("ds") && e.to_string().contains("not empty"),
        "{e}"
    );
    assert_eq!(listing(&target), ["old.txt"]);

    let ad = AtomicDir::create(&target, true).unwrap();
    fs::write(ad.join("new.txt"), b"new").unwrap();
    ad.commit().unwrap();
    assert_eq!(
        listing(&target),
        ["new.txt"],
        "old files gone, new ones in place"
    );
    assert_eq!(listing(&d), ["ds"], "no temporary or old folder left");
}

#[test]
fn atomic_dir_replaces_empty_folder_and_rechecks_at_commit() {
    let d = scratch("dir-empty");
    let target = d.join("ds");
    fs::create_dir(&target).unwrap();
    let ad = AtomicDir::create(&target, false).unwrap();
    fs::write(ad.join("a"), b"1").unwrap();
    ad.commit().unwrap();
    assert_eq!(listing(&target), ["a"]);

    // Someone fills the target while we write: the commit must not clobber it.
    let other = d.join("ds2");
    let ad = AtomicDir::create(&other, false).unwrap();
    fs::write(ad.join("mine"), b"1").unwrap();
    fs::create_dir(&other).unwrap();
    fs::write(other.join("theirs"), b"2").unwrap();
    let e = ad.commit().unwrap_err();
    assert!(matches!(e, AtomicError::NotEmpty { .. }), "{e}");
    assert_eq!(listing(&other), ["theirs"]);
    assert_eq!(
        listing(&d),
        ["ds", "ds2"],
        "temporary folder removed after the failed commit"
    );
}

#[test]
fn atomic_dir_never_replaces_a_file() {
    let d = scratch("dir-file");
    let target = d.join("ds");
    fs::write(&target, b"file").unwrap();
    let e = AtomicDir::create(&target, true).unwrap_err();
    assert!(matches!(e, AtomicError::WrongKind { .. }), "{e}");
    assert_eq!(fs::read(&target).unwrap(), b"file");
}
