//! The outputs of one run, all or nothing: every path is checked before the work starts, every
//! file is written to a temporary file beside it, and the temporaries are put in place only
//! once every output of the run has been written. A run that fails leaves nothing new behind
//! and every old file intact.
//!
//! Paths are resolved by [`Destination`]: `-` and `/dev/stdout` are standard output, a device
//! node or FIFO is written through (never replaced), a symbolic link is followed and its target
//! replaced in the target's own folder.
//!
//! Under MPI only rank 0 writes: on the other ranks ([`crate::team::is_root`]) every output is
//! accepted unchecked and every write is dropped (docs/ARCHITECTURE.md §4.3).

use crate::error::{Error, Result};
use crate::export::{Schema, Stamp};
use crate::geometry::{write_atomic, Destination, Staged};
use std::io::Write;
use std::path::{Path, PathBuf};

/// One output of a run, as handed out by [`Outputs::add`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Output(usize);

/// The outputs of a run (see the module docs).
#[derive(Debug, Default)]
pub struct Outputs {
    items: Vec<Item>,
    /// The run's command line, stamped on its JSON reports.
    command: Vec<String>,
    /// A rank other than 0: nothing is checked or written.
    mute: bool,
    /// Where a muted rank's piecewise outputs go.
    sink: std::io::Sink,
}

#[derive(Debug)]
struct Item {
    /// The option that named it (`--json`), for messages.
    flag: String,
    /// The path as given.
    path: PathBuf,
    /// Where it leads.
    dest: Destination,
    /// The output being written (`None` for an output written during the run).
    staged: Option<Staged>,
    /// Whether anything was put into `staged`.
    filled: bool,
    /// An output written during the run ([`Outputs::interim`]): once written, what the file
    /// held before (`None`: there was no file), restored if the run fails.
    before: Option<Option<Vec<u8>>>,
    /// Whether the output is written during the run.
    is_interim: bool,
}

impl Outputs {
    /// No outputs yet, for the run of `command` (its arguments, the program first), which the
    /// JSON reports are stamped with.
    #[must_use]
    pub fn new(command: Vec<String>) -> Self {
        Outputs {
            items: Vec::new(),
            command,
            mute: !crate::team::is_root(),
            sink: std::io::sink(),
        }
    }

    /// Check `path`, given to `flag`, before any work: it leads to standard output, a
    /// special file that opens for writing, or a regular file (existing or not) that is no
    /// folder, in a folder that exists and takes a new file (its temporary file is created
    /// now). Two outputs may not lead to the same file, nor two to standard output.
    pub fn add(&mut self, flag: &str, path: &Path) -> Result<Output> {
        self.insert(flag, path, false)
    }

    /// [`add`](Self::add) for an optional path.
    pub fn add_opt(&mut self, flag: &str, path: Option<&Path>) -> Result<Option<Output>> {
        path.map(|p| self.add(flag, p)).transpose()
    }

    /// Check `path` as [`add`](Self::add) does, for an output written during the run with
    /// [`interim`](Self::interim) (checkpoints) rather than at the end.
    pub fn add_interim(&mut self, flag: &str, path: &Path) -> Result<Output> {
        self.insert(flag, path, true)
    }

    fn insert(&mut self, flag: &str, path: &Path, is_interim: bool) -> Result<Output> {
        if self.mute {
            self.items.push(Item {
                flag: flag.to_string(),
                path: path.to_path_buf(),
                dest: Destination::Special(path.to_path_buf()),
                staged: None,
                filled: true,
                before: None,
                is_interim,
            });
            return Ok(Output(self.items.len() - 1));
        }
        let staged = Staged::create(path).map_err(|e| Error::invalid(format!("{flag} {e}")))?;
        let dest = staged.destination().clone();
        if let Some(other) = self.items.iter().find(|i| i.dest == dest) {
            return Err(Error::invalid(match dest {
                Destination::Stdout => format!(
                    "{} and {flag} both go to standard output; give one of them a file",
                    other.flag
                ),
                _ => format!(
                    "{} and {flag} both name {}; give each output its own file",
                    other.flag,
                    path.display()
                ),
            }));
        }
        self.items.push(Item {
            flag: flag.to_string(),
            path: path.to_path_buf(),
            dest,
            // An output written during the run only needed the check.
            staged: (!is_interim).then_some(staged),
            filled: false,
            before: None,
            is_interim,
        });
        Ok(Output(self.items.len() - 1))
    }

    /// True when one of the outputs goes to standard output (readable text then goes to
    /// standard error, so that standard output stays parseable).
    #[must_use]
    pub fn uses_stdout(&self) -> bool {
        self.items.iter().any(|i| i.dest == Destination::Stdout)
    }

    /// The writer of `o`'s content (its temporary file, or memory for standard output and
    /// special files), for outputs written piece by piece (a history file).
    pub fn writer(&mut self, o: Output) -> Result<&mut dyn Write> {
        if self.mute {
            return Ok(&mut self.sink);
        }
        let item = &mut self.items[o.0];
        item.filled = true;
        match &mut item.staged {
            Some(staged) => Ok(staged.writer()),
            None => Err(Error::invalid(format!(
                "{} is written during the run, not piece by piece",
                item.flag
            ))),
        }
    }

    /// The path given for `o`, for messages.
    #[must_use]
    pub fn path(&self, o: Output) -> &Path {
        &self.items[o.0].path
    }

    /// Set `o`'s whole content.
    pub fn put(&mut self, o: Output, bytes: &[u8]) -> Result<()> {
        if self.mute {
            return Ok(());
        }
        let item = &mut self.items[o.0];
        let Some(staged) = item.staged.as_mut() else {
            return Err(Error::Output(format!(
                "{} is written during the run, not at its end",
                item.flag
            )));
        };
        staged.clear()?;
        staged.writer().write_all(bytes).map_err(|source| Error::Io {
            path: item.path.clone(),
            source,
        })?;
        item.filled = true;
        Ok(())
    }

    /// Set `o`'s content to the report `value` of `schema` as pretty JSON with a final
    /// newline, stamped ([`Stamp`]) with this run's command line.
    pub fn put_json<T: serde::Serialize>(&mut self, o: Output, schema: Schema, value: &T) -> Result<()> {
        let stamp = Stamp::new(schema, self.command.clone());
        let mut text =
            serde_json::to_string_pretty(&stamp.on(value)).map_err(|e| Error::Output(e.to_string()))?;
        text.push('\n');
        self.put(o, text.as_bytes())
    }

    /// Replace `o` now, during the run (a checkpoint: each write a whole, valid state that a
    /// later run can resume). A regular file is replaced atomically; what it held before the
    /// run's first write is kept in memory and put back if the run fails, so a failed run
    /// leaves the old file (or no file) as it found it.
    pub fn interim(&mut self, o: Output, bytes: &[u8]) -> Result<()> {
        if self.mute {
            return Ok(());
        }
        let item = &mut self.items[o.0];
        if !item.is_interim {
            return Err(Error::invalid(format!(
                "{} is written at the end of the run",
                item.flag
            )));
        }
        if let (Destination::File(target), None) = (&item.dest, &item.before) {
            item.before = Some(match std::fs::read(target) {
                Ok(old) => Some(old),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
                Err(source) => {
                    return Err(Error::Io {
                        path: item.path.clone(),
                        source,
                    })
                }
            });
        }
        write_atomic(&item.path, |w| w.write_all(bytes))?;
        item.filled = true;
        Ok(())
    }

    /// Put every output in place: the temporary files are flushed and synced (where a full
    /// disk shows), then standard output and special files are written, then the temporary
    /// files renamed over their targets. An error before the renames leaves every file as it
    /// was.
    pub fn commit(&mut self) -> Result<()> {
        if self.mute {
            return Ok(());
        }
        for item in &mut self.items {
            if !item.filled {
                return Err(Error::Output(format!(
                    "{} {}: nothing was produced for it",
                    item.flag,
                    item.path.display()
                )));
            }
            if let Some(staged) = item.staged.as_mut() {
                staged.finish()?;
            }
        }
        let mut staged: Vec<Staged> = self.items.iter_mut().filter_map(|i| i.staged.take()).collect();
        // Written through first: they cannot be undone, and a failure among them (a full
        // device) must still leave every regular file as it was.
        staged.sort_by_key(|s| matches!(s.destination(), Destination::File(_)));
        for s in staged {
            s.commit()?;
        }
        // The outputs written during the run are final now.
        for item in &mut self.items {
            item.before = None;
        }
        Ok(())
    }
}

impl Drop for Outputs {
    /// A run that did not commit: temporary files go (each [`Staged`] removes its own), and
    /// the files written during the run are put back as they were.
    fn drop(&mut self) {
        for item in &mut self.items {
            let (Destination::File(target), Some(before)) = (&item.dest, item.before.take()) else {
                continue;
            };
            // Best effort: there is no one left to tell.
            let _ = match before {
                Some(old) => write_atomic(target, |w| w.write_all(&old)).map_err(|_| ()),
                None => std::fs::remove_file(target).map_err(|_| ()),
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn listing(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// A run's outputs whose first is `--json` naming `a.json` in `d`, holding `old` (none: the
    /// file as it is).
    fn with_json(d: &Path, old: Option<&str>) -> (Outputs, Output) {
        if let Some(text) = old {
            std::fs::write(d.join("a.json"), text).unwrap();
        }
        let mut outs = Outputs::new(Vec::new());
        let a = outs.add("--json", &d.join("a.json")).unwrap();
        (outs, a)
    }

    #[test]
    fn every_output_or_none() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // Checked before the work: a missing folder and a folder are refused by name.
        let (mut outs, a) = with_json(d, Some("old"));
        let e = outs
            .add("--svg", &d.join("missing/x.svg"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--svg ") && e.contains("does not exist"), "{e}");
        let e = outs.add("--png", d).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        // Committed: both files in place, nothing else.
        let b = outs.add("--svg", &d.join("b.svg")).unwrap();
        outs.put(a, b"new").unwrap();
        outs.put(b, b"<svg/>").unwrap();
        outs.commit().unwrap();
        assert_eq!(listing(d), ["a.json", "b.svg"]);
        assert_eq!(std::fs::read_to_string(d.join("a.json")).unwrap(), "new");
        // Not committed (the run failed): nothing new, the old files intact.
        let (mut outs, a) = with_json(d, None);
        outs.add("--obj", &d.join("c.obj")).unwrap();
        outs.put(a, b"newer").unwrap();
        drop(outs);
        assert_eq!(listing(d), ["a.json", "b.svg"]);
        assert_eq!(std::fs::read_to_string(d.join("a.json")).unwrap(), "new");
    }

    #[cfg(unix)]
    #[test]
    fn a_failing_device_leaves_the_files_alone() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let (mut outs, a) = with_json(d, Some("old"));
        let full = outs.add("--svg", Path::new("/dev/full")).unwrap();
        outs.put(a, b"new").unwrap();
        outs.put(full, b"<svg/>").unwrap();
        assert!(outs.commit().is_err());
        assert_eq!(listing(d), ["a.json"]);
        assert_eq!(std::fs::read_to_string(d.join("a.json")).unwrap(), "old");
    }

    #[test]
    fn outputs_may_not_collide() {
        let dir = tempfile::tempdir().unwrap();
        let mut outs = Outputs::new(Vec::new());
        outs.add("--json", Path::new("-")).unwrap();
        let e = outs
            .add("--svg", Path::new("/dev/stdout"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("standard output"), "{e}");
        outs.add("--obj", &dir.path().join("x")).unwrap();
        let e = outs.add("--stl", &dir.path().join("x")).unwrap_err().to_string();
        assert!(e.contains("--obj and --stl both name"), "{e}");
    }

    #[test]
    fn files_written_during_a_failed_run_are_put_back() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("run.ckpt"), "old state").unwrap();
        let mut outs = Outputs::new(Vec::new());
        let old = outs.add_interim("--checkpoint", &d.join("run.ckpt")).unwrap();
        let new = outs.add_interim("--checkpoint", &d.join("new.ckpt")).unwrap();
        outs.interim(old, b"state 10").unwrap();
        outs.interim(new, b"state 10").unwrap();
        assert_eq!(std::fs::read_to_string(d.join("run.ckpt")).unwrap(), "state 10");
        drop(outs);
        assert_eq!(listing(d), ["run.ckpt"]);
        assert_eq!(std::fs::read_to_string(d.join("run.ckpt")).unwrap(), "old state");
        // Committed, the last state stays.
        let mut outs = Outputs::new(Vec::new());
        let ck = outs.add_interim("--checkpoint", &d.join("run.ckpt")).unwrap();
        let hist = outs.add("--history", &d.join("h.csv")).unwrap();
        outs.interim(ck, b"state 20").unwrap();
        writeln!(outs.writer(hist).unwrap(), "generation,best").unwrap();
        outs.commit().unwrap();
        assert_eq!(listing(d), ["h.csv", "run.ckpt"]);
        assert_eq!(std::fs::read_to_string(d.join("run.ckpt")).unwrap(), "state 20");
        assert_eq!(
            std::fs::read_to_string(d.join("h.csv")).unwrap(),
            "generation,best\n"
        );
    }
}
