//! File plumbing shared by the readers and writers: bounded reads (size, line length,
//! encoding), all-or-nothing writes that follow symbolic links and write through special files,
//! line splitting, field tokenising and strict number parsing.

use crate::error::{Error, Result};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Longest excerpt of an offending line quoted in an error message, in characters.
const EXCERPT: usize = 48;

/// The largest file bezchain reads, in bytes: 1 GiB (a CSV cloud of some 20 million points).
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// The longest line of a text file bezchain reads, in bytes: 1 MiB.
pub const MAX_LINE_BYTES: u64 = 1 << 20;

/// Bytes read at a time; far below [`MAX_LINE_BYTES`], so a line longer than that limit
/// spans whole chunks without a line end (which is how [`read_limited`] finds it).
const CHUNK: usize = 1 << 16;

/// Where an output path leads, symbolic links followed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Destination {
    /// This process's standard output: `-`, `/dev/stdout`, `/dev/fd/1`, `/proc/self/fd/1`.
    Stdout,
    /// Not a regular file (a device node, a FIFO, a socket, an open descriptor under
    /// `/dev/fd`): written through in place, never replaced.
    Special(PathBuf),
    /// A regular file, existing or not, at this path with every symbolic link resolved: a
    /// temporary file in its folder is renamed over it, so the link (if any) is kept and its
    /// target replaced whole.
    File(PathBuf),
}

impl Destination {
    /// Where `path` leads, checked as far as it can be before anything is written: a path
    /// that is (or leads to) a folder, a folder that does not exist, or a chain of symbolic
    /// links that does not end is refused ([`Error::Invalid`], naming `path`).
    pub fn resolve(path: &Path) -> Result<Destination> {
        /// Links followed before giving up, as the kernel does (`ELOOP`).
        const MAX_LINKS: usize = 40;
        let shown = path.display();
        if path.as_os_str() == "-" {
            return Ok(Destination::Stdout);
        }
        let mut at = path.to_path_buf();
        for _ in 0..=MAX_LINKS {
            if let Some(fd) = descriptor(&at) {
                return Ok(if fd == 1 {
                    Destination::Stdout
                } else {
                    Destination::Special(at)
                });
            }
            match std::fs::symlink_metadata(&at) {
                Ok(m) if m.file_type().is_symlink() => {
                    let target = std::fs::read_link(&at).map_err(|source| Error::Io {
                        path: at.clone(),
                        source,
                    })?;
                    at = match at.parent() {
                        Some(dir) if target.is_relative() => dir.join(target),
                        _ => target,
                    };
                }
                Ok(m) if m.is_dir() => {
                    return Err(Error::invalid(format!("{shown}: is a folder, not a file")));
                }
                Ok(m) if m.is_file() => return Ok(Destination::File(at)),
                Ok(_) => return Ok(Destination::Special(at)),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                    let dir = folder_of(&at);
                    return match std::fs::metadata(&dir) {
                        Ok(m) if m.is_dir() => Ok(Destination::File(at)),
                        Ok(_) => Err(Error::invalid(format!(
                            "{shown}: {} is not a folder",
                            dir.display()
                        ))),
                        Err(_) => Err(Error::invalid(format!(
                            "{shown}: the folder {} does not exist",
                            dir.display()
                        ))),
                    };
                }
                Err(source) => return Err(Error::Io { path: at, source }),
            }
        }
        Err(Error::invalid(format!(
            "{shown}: more than {MAX_LINKS} symbolic links in a row (a loop?)"
        )))
    }
}

/// The descriptor an output path names directly (`/dev/stdout`, `/dev/fd/N`,
/// `/proc/self/fd/N`): such a path is written through, since following its link would
/// replace whatever the descriptor is open on (a terminal, a pipe, a file the shell opened).
fn descriptor(path: &Path) -> Option<u32> {
    let s = path.to_str()?;
    match s {
        "/dev/stdout" => return Some(1),
        "/dev/stderr" => return Some(2),
        _ => {}
    }
    let n = s
        .strip_prefix("/dev/fd/")
        .or_else(|| s.strip_prefix("/proc/self/fd/"))
        .or_else(|| s.strip_prefix("/proc/thread-self/fd/"))?;
    n.parse().ok()
}

/// The folder a file path lies in (`.` for a bare name).
fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// One output being written. For a regular file the bytes go to a temporary file in the
/// target's folder (created by [`create`](Self::create), so an unwritable folder is found
/// before any work), which [`commit`](Self::commit) renames over the target; otherwise they are
/// kept in memory and written through at commit. Dropped without a commit, it removes its
/// temporary file and leaves the target alone.
#[derive(Debug)]
pub struct Staged {
    dest: Destination,
    /// The temporary file and its writer (regular files).
    tmp: Option<(PathBuf, BufWriter<File>)>,
    /// The bytes for a destination that is written through.
    buf: Vec<u8>,
}

impl Staged {
    /// Resolve `path` ([`Destination::resolve`]) and prepare its output: a temporary file
    /// beside a regular file (with the permissions of the file it will replace), or for a
    /// device node a check that it opens for writing. Nothing at `path` changes.
    pub fn create(path: &Path) -> Result<Staged> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let dest = Destination::resolve(path)?;
        let tmp = match &dest {
            Destination::File(target) => {
                let io = |source| Error::Io {
                    path: path.to_path_buf(),
                    source,
                };
                let file_name = target
                    .file_name()
                    .ok_or_else(|| Error::invalid(format!("{}: not a file name", path.display())))?;
                let dir = folder_of(target);
                // A name no other writer (thread or process) uses; `create_new` refuses to
                // reuse one.
                let (tmp, file) = loop {
                    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
                    let mut name = std::ffi::OsString::from(".");
                    name.push(file_name);
                    name.push(format!(".tmp-{}-{n}", std::process::id()));
                    let tmp = dir.join(name);
                    match OpenOptions::new().write(true).create_new(true).open(&tmp) {
                        Ok(f) => break (tmp, f),
                        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                        Err(e) => return Err(io(e)),
                    }
                };
                if let Ok(old) = std::fs::metadata(target) {
                    // Best effort: a replaced file keeps its mode (an executable script stays
                    // executable).
                    let _ = file.set_permissions(old.permissions());
                }
                Some((tmp, BufWriter::with_capacity(CHUNK, file)))
            }
            Destination::Special(p) if !is_fifo(p) => {
                // A FIFO is opened at commit (opening it waits for a reader); anything else
                // must open for writing now.
                OpenOptions::new()
                    .write(true)
                    .open(p)
                    .map_err(|source| Error::Io {
                        path: path.to_path_buf(),
                        source,
                    })?;
                None
            }
            _ => None,
        };
        Ok(Staged {
            dest,
            tmp,
            buf: Vec::new(),
        })
    }

    /// Where the output goes.
    #[must_use]
    pub fn destination(&self) -> &Destination {
        &self.dest
    }

    /// The writer of the output's bytes.
    pub fn writer(&mut self) -> &mut dyn Write {
        match &mut self.tmp {
            Some((_, w)) => w,
            None => &mut self.buf,
        }
    }

    /// Forget what was written so far (a temporary file is truncated).
    pub fn clear(&mut self) -> Result<()> {
        self.buf.clear();
        if let Some((tmp, w)) = &mut self.tmp {
            let io = |source| Error::Io {
                path: tmp.clone(),
                source,
            };
            w.flush().map_err(io)?;
            w.get_ref().set_len(0).map_err(io)?;
            std::io::Seek::rewind(w.get_mut()).map_err(io)?;
        }
        Ok(())
    }

    /// Flush and sync a temporary file (the step that finds a full disk), so that the
    /// commit is a rename alone.
    pub fn finish(&mut self) -> Result<()> {
        if let Some((tmp, w)) = &mut self.tmp {
            w.flush()
                .and_then(|()| w.get_ref().sync_all())
                .map_err(|source| Error::Io {
                    path: tmp.clone(),
                    source,
                })?;
        }
        Ok(())
    }

    /// Put the output in place: write it through, or rename the temporary file over the
    /// target.
    pub fn commit(mut self) -> Result<()> {
        self.finish()?;
        match &self.dest {
            Destination::Stdout => {
                let mut out = std::io::stdout().lock();
                out.write_all(&self.buf)
                    .and_then(|()| out.flush())
                    .map_err(|source| Error::Io {
                        path: PathBuf::from("standard output"),
                        source,
                    })
            }
            Destination::Special(p) => OpenOptions::new()
                .write(true)
                .open(p)
                .and_then(|mut f| f.write_all(&self.buf).and_then(|()| f.flush()))
                .map_err(|source| Error::Io {
                    path: p.clone(),
                    source,
                }),
            Destination::File(target) => {
                let Some((tmp, _)) = self.tmp.take() else {
                    return Err(Error::Output(format!(
                        "{}: the temporary file is gone",
                        target.display()
                    )));
                };
                std::fs::rename(&tmp, target).map_err(|source| {
                    let _ = std::fs::remove_file(&tmp);
                    Error::Io {
                        path: target.clone(),
                        source,
                    }
                })
            }
        }
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some((tmp, _)) = self.tmp.take() {
            // Best effort: the temporary file is ours and useless now.
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// True when `path` is a FIFO (named pipe).
fn is_fifo(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        std::fs::metadata(path).is_ok_and(|m| m.file_type().is_fifo())
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        false
    }
}

/// Write `path` all or nothing: `fill` writes the bytes, which go to a temporary file in the
/// target's folder that is flushed, synced and renamed over it ([`Staged`]). A symbolic link
/// is followed and its target replaced; a device node, a FIFO or `/dev/stdout` is written
/// through in place (never replaced).
///
/// Whatever happens (an error from `fill`, a full disk, a crash), a regular file holds either
/// its old contents or the complete new ones, never a half-written file; the temporary file is
/// removed on failure.
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
{
    let mut staged = Staged::create(path)?;
    fill(staged.writer()).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    staged.commit()
}

/// Read a whole file, at most [`MAX_INPUT_BYTES`] (binary files: checkpoints).
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    read_limited(path, false)
}

/// Read a whole text file: at most [`MAX_INPUT_BYTES`], lines of at most
/// [`MAX_LINE_BYTES`], no NUL bytes, UTF-8 (a leading byte-order mark is dropped; UTF-16 is
/// refused with a message saying so). Every error names the file, and the line where there is
/// one. `/dev/zero` is refused after reading one line's limit.
pub(crate) fn read_text(path: &Path) -> Result<String> {
    text_from_bytes(read_limited(path, true)?, path)
}

/// Whether `path` is `-`, standard input.
#[must_use]
pub fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Standard input's bytes, read whole on the first call (a command may read its input twice:
/// to tell a report from coordinates, then to parse it) up to the size limit of a file's.
fn stdin_bytes() -> Result<Vec<u8>> {
    static STDIN: std::sync::Mutex<Option<Vec<u8>>> = std::sync::Mutex::new(None);
    let mut cached = STDIN.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if cached.is_none() {
        *cached = Some(read_from(std::io::stdin().lock(), Path::new("-"), None, false)?);
    }
    Ok(cached.clone().unwrap_or_default())
}

/// Read `path` (`-`: standard input) in chunks, stopping at the size limit and, for text, at
/// an over-long line or a NUL byte, before more memory is spent on it.
fn read_limited(path: &Path, text: bool) -> Result<Vec<u8>> {
    if is_stdin(path) {
        let bytes = stdin_bytes()?;
        return if text {
            read_from(bytes.as_slice(), path, None, true)
        } else {
            Ok(bytes)
        };
    }
    let file = File::open(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let size = file.metadata().ok().filter(|m| m.is_file()).map(|m| m.len());
    read_from(file, path, size, text)
}

/// [`read_limited`] of an open `reader` that `path` names (`size`: its length, where known).
fn read_from(mut reader: impl std::io::Read, path: &Path, size: Option<u64>, text: bool) -> Result<Vec<u8>> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let too_big = || Error::Input {
        path: path.to_path_buf(),
        message: format!(
            "larger than {} MiB, the most bezchain reads (is it the right file?)",
            MAX_INPUT_BYTES >> 20
        ),
    };
    if size.is_some_and(|n| n > MAX_INPUT_BYTES) {
        return Err(too_big());
    }
    let mut out: Vec<u8> = Vec::with_capacity(size.unwrap_or(0) as usize);
    let mut chunk = vec![0u8; CHUNK];
    // Bytes since the last line end.
    let mut run: u64 = 0;
    let line_at = |out: &[u8]| 1 + out.iter().filter(|&&b| b == b'\n').count();
    loop {
        let n = match reader.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(io(e)),
        };
        if out.len() as u64 + n as u64 > MAX_INPUT_BYTES {
            return Err(too_big());
        }
        let got = &chunk[..n];
        if text {
            if out.is_empty() {
                if let Some(bom) = utf16_bom(got) {
                    return Err(Error::Parse {
                        path: path.to_path_buf(),
                        line: 1,
                        message: format!("UTF-16 text (byte-order mark {bom}): save the file as UTF-8"),
                    });
                }
            }
            if let Some(k) = got.iter().position(|&b| b == 0) {
                out.extend_from_slice(&got[..k]);
                return Err(Error::Parse {
                    path: path.to_path_buf(),
                    line: line_at(&out),
                    message: "a NUL byte: not a text file".into(),
                });
            }
            match got.iter().rposition(|&b| b == b'\n' || b == b'\r') {
                Some(k) => run = (n - k - 1) as u64,
                None => run += n as u64,
            }
            if run > MAX_LINE_BYTES {
                return Err(Error::Parse {
                    path: path.to_path_buf(),
                    line: line_at(&out),
                    message: format!(
                        "a line longer than {} KiB, the most bezchain reads (not a text file of points?)",
                        MAX_LINE_BYTES >> 10
                    ),
                });
            }
        }
        out.extend_from_slice(got);
    }
    Ok(out)
}

/// The byte-order mark of UTF-16 text, if `bytes` start with one.
fn utf16_bom(bytes: &[u8]) -> Option<&'static str> {
    match bytes {
        [0xFF, 0xFE, ..] => Some("FF FE"),
        [0xFE, 0xFF, ..] => Some("FE FF"),
        _ => None,
    }
}

/// UTF-8 text from raw bytes, or a parse error at the line of the first invalid byte.
pub(crate) fn text_from_bytes(bytes: Vec<u8>, path: &Path) -> Result<String> {
    match String::from_utf8(bytes) {
        Ok(mut s) => {
            if s.starts_with('\u{feff}') {
                s.drain(..'\u{feff}'.len_utf8());
            }
            Ok(s)
        }
        Err(e) => {
            let at = e.utf8_error().valid_up_to();
            let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
            Err(Error::Parse {
                path: path.to_path_buf(),
                line,
                message: "not UTF-8 text (a binary file, or another encoding: save it as UTF-8)".into(),
            })
        }
    }
}

/// Deserialize a JSON value as `T`; the error names the field where it failed, its JSON path
/// after `at` (`field 'control_points[3][1]': invalid type: sequence, expected f64`).
pub(crate) fn from_json_value<T: serde::de::DeserializeOwned>(
    value: serde_json::Value,
    at: &str,
) -> std::result::Result<T, String> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let field = json_field(at, &e.path().to_string());
        format!("{field}{}", e.into_inner())
    })
}

/// Parse JSON text as `T`: a syntax error is a parse error at its line, a value of the wrong
/// type or a missing field names the field (its JSON path) and the line; `what` ("not a
/// bezchain curve report") opens the message of the latter.
pub(crate) fn parse_json<T: serde::de::DeserializeOwned>(text: &str, path: &Path, what: &str) -> Result<T> {
    let mut de = serde_json::Deserializer::from_str(text);
    let value: T = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let field = json_field("", &e.path().to_string());
        let inner = e.into_inner();
        let message = if inner.is_syntax() || inner.is_eof() {
            format!("not valid JSON: {inner}")
        } else {
            format!("{what}: {field}{inner}")
        };
        Error::Parse {
            path: path.to_path_buf(),
            line: inner.line().max(1),
            message,
        }
    })?;
    de.end().map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        line: e.line().max(1),
        message: format!("not valid JSON: {e}"),
    })?;
    Ok(value)
}

/// `field 'a.b[2]': ` for a serde path after the prefix `at`; nothing at the root.
fn json_field(at: &str, path: &str) -> String {
    let path = if path == "." { "" } else { path };
    let full = match (at.is_empty(), path.is_empty()) {
        (_, true) => at.trim_end_matches('.').to_string(),
        (true, false) => path.to_string(),
        (false, false) if path.starts_with('[') => format!("{}{path}", at.trim_end_matches('.')),
        (false, false) => format!("{at}{path}"),
    };
    if full.is_empty() {
        String::new()
    } else {
        format!("field '{full}': ")
    }
}

/// The lines of `text` with their 1-based numbers, line ends (`\n`, `\r\n`, or a lone `\r` in
/// files that have no `\n` at all) removed.
pub(crate) fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let sep = if text.contains('\n') { '\n' } else { '\r' };
    text.split(sep)
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .enumerate()
        .map(|(i, l)| (i + 1, l))
}

/// `line` without a trailing `# comment`.
pub(crate) fn strip_comment(line: &str) -> &str {
    match line.find('#') {
        Some(i) => &line[..i],
        None => line,
    }
}

/// Split a data line into fields. Fields are separated by runs of spaces/tabs or by one comma or
/// semicolon (with optional blanks around it). An empty field (`1,,2`) is an error; a single
/// trailing separator is tolerated. Returns whether a comma or semicolon was seen.
pub(crate) fn split_fields<'a>(line: &'a str, out: &mut Vec<&'a str>) -> std::result::Result<bool, String> {
    out.clear();
    let is_blank = |b: u8| b == b' ' || b == b'\t';
    let is_hard = |b: u8| b == b',' || b == b';';
    let s = line.trim_matches(|c| c == ' ' || c == '\t');
    let b = s.as_bytes();
    let mut i = 0;
    let mut hard_seen = false;
    while i < b.len() {
        let start = i;
        while i < b.len() && !is_blank(b[i]) && !is_hard(b[i]) {
            i += 1;
        }
        let field = &s[start..i];
        while i < b.len() && is_blank(b[i]) {
            i += 1;
        }
        if i < b.len() && is_hard(b[i]) {
            hard_seen = true;
            i += 1;
            while i < b.len() && is_blank(b[i]) {
                i += 1;
            }
        }
        if field.is_empty() {
            return Err(format!("empty field in '{}'", excerpt(line)));
        }
        out.push(field);
    }
    Ok(hard_seen)
}

/// How a field failed to be a usable number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BadNumber {
    /// Not a number at all.
    NotNumeric,
    /// A number, but NaN or infinite (or out of the f64 range).
    NotFinite,
}

/// Parse one field as a finite f64. Accepts Fortran `D` exponents (`1.5D-03`).
pub(crate) fn parse_number(field: &str) -> std::result::Result<f64, BadNumber> {
    let v = match field.parse::<f64>() {
        Ok(v) => v,
        Err(_) if field.contains(['d', 'D']) && field.len() < 64 => field
            .replace(['d', 'D'], "e")
            .parse::<f64>()
            .map_err(|_| BadNumber::NotNumeric)?,
        Err(_) => return Err(BadNumber::NotNumeric),
    };
    if v.is_finite() {
        Ok(v)
    } else {
        Err(BadNumber::NotFinite)
    }
}

/// `text` trimmed and shortened to at most [`EXCERPT`] characters for an error message.
pub(crate) fn excerpt(text: &str) -> String {
    let t = text.trim();
    if t.chars().count() <= EXCERPT {
        t.to_string()
    } else {
        let head: String = t.chars().take(EXCERPT - 1).collect();
        format!("{head}…")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fields(s: &str) -> std::result::Result<(Vec<&str>, bool), String> {
        let mut v = Vec::new();
        let hard = split_fields(s, &mut v)?;
        Ok((v, hard))
    }

    #[test]
    fn fields_split_on_every_separator() {
        assert_eq!(fields("1 2").unwrap(), (vec!["1", "2"], false));
        assert_eq!(fields("\t1\t\t2  ").unwrap(), (vec!["1", "2"], false));
        assert_eq!(fields("1,2;3").unwrap(), (vec!["1", "2", "3"], true));
        assert_eq!(fields("1 , 2 ,3,").unwrap(), (vec!["1", "2", "3"], true));
        assert_eq!(fields("").unwrap(), (vec![], false));
        assert!(fields("1,,2").is_err());
        assert!(fields(",1,2").is_err());
        assert!(fields("1, ,2").is_err());
    }

    #[test]
    fn numbers_are_strict_and_finite() {
        assert_eq!(parse_number("-.0046700"), Ok(-0.00467));
        assert_eq!(parse_number("1.5D-03"), Ok(1.5e-3));
        assert_eq!(parse_number("61."), Ok(61.0));
        assert_eq!(parse_number("nan"), Err(BadNumber::NotFinite));
        assert_eq!(parse_number("-inf"), Err(BadNumber::NotFinite));
        assert_eq!(parse_number("1e999"), Err(BadNumber::NotFinite));
        assert_eq!(parse_number("abc"), Err(BadNumber::NotNumeric));
        assert_eq!(parse_number("1d"), Err(BadNumber::NotNumeric));
    }

    #[test]
    fn lines_handle_every_line_end() {
        let crlf: Vec<_> = numbered_lines("a\r\nb\r\n").collect();
        assert_eq!(crlf, vec![(1, "a"), (2, "b"), (3, "")]);
        let cr: Vec<_> = numbered_lines("a\rb").collect();
        assert_eq!(cr, vec![(1, "a"), (2, "b")]);
    }

    #[test]
    fn invalid_utf8_names_its_line() {
        let err = text_from_bytes(b"ok\nok\n\xff\xfe".to_vec(), Path::new("f")).unwrap_err();
        assert!(matches!(err, Error::Parse { line: 3, .. }), "{err}");
        assert_eq!(text_from_bytes("\u{feff}x".into(), Path::new("f")).unwrap(), "x");
    }

    #[test]
    fn excerpts_are_short() {
        let long = "x".repeat(500);
        assert_eq!(excerpt(&long).chars().count(), EXCERPT);
        assert_eq!(excerpt("  short "), "short");
    }

    #[test]
    fn atomic_write_replaces_whole_or_not_at_all() {
        let dir = std::env::temp_dir().join(format!("bezchain-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("out.txt");
        write_atomic(&path, |w| w.write_all(b"first")).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "first");
        // A failing writer leaves the old file and no temporary behind.
        let err = write_atomic(&path, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk full"))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "first");
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(left.len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn reads_are_bounded_and_name_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let long = dir.path().join("long.dat");
        let mut text = b"name\n0 0\n".to_vec();
        text.resize(text.len() + MAX_LINE_BYTES as usize + 10, b'1');
        std::fs::write(&long, &text).unwrap();
        let e = read_text(&long).unwrap_err();
        assert!(matches!(e, Error::Parse { line: 3, .. }), "{e}");
        assert!(e.to_string().contains("longer than 1024 KiB"), "{e}");
        let nul = dir.path().join("nul.dat");
        std::fs::write(&nul, b"1 2\n3 4\n5\x006\n").unwrap();
        let e = read_text(&nul).unwrap_err();
        assert!(matches!(e, Error::Parse { line: 3, .. }), "{e}");
        let utf16 = dir.path().join("utf16.dat");
        std::fs::write(&utf16, b"\xff\xfe1\x00 \x002\x00").unwrap();
        let e = read_text(&utf16).unwrap_err().to_string();
        assert!(e.contains("UTF-16") && e.contains("utf16.dat:1"), "{e}");
        // An endless source without line ends stops at the line limit.
        #[cfg(unix)]
        {
            let e = read_text(Path::new("/dev/zero")).unwrap_err();
            assert!(e.to_string().contains("NUL"), "{e}");
        }
        let bom = dir.path().join("bom.dat");
        std::fs::write(&bom, "\u{feff}1 2\n").unwrap();
        assert_eq!(read_text(&bom).unwrap(), "1 2\n");
        assert!(matches!(read_text(dir.path()), Err(Error::Io { .. })));
    }

    #[test]
    fn json_errors_name_the_field_and_line() {
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct R {
            a: Vec<[f64; 2]>,
        }
        let e = parse_json::<R>("{\"a\": [[1, 2],\n [3, [4]]]}", Path::new("r.json"), "not an R")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("r.json:2: not an R: field 'a[1][1]': invalid type"),
            "{e}"
        );
        let e = parse_json::<R>("{\"a\": [", Path::new("r.json"), "not an R")
            .unwrap_err()
            .to_string();
        assert!(e.contains("not valid JSON"), "{e}");
        let v: serde_json::Value = serde_json::json!({"a": [[1, "x"]]});
        let e = from_json_value::<R>(v, "adapt.").unwrap_err();
        assert!(e.starts_with("field 'adapt.a[0][1]'"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn outputs_follow_links_and_write_through_special_files() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // A link to a file: the target is replaced, the link stays a link.
        std::fs::create_dir(d.join("real")).unwrap();
        std::fs::write(d.join("real/out.txt"), "old").unwrap();
        std::os::unix::fs::symlink("real/out.txt", d.join("link.txt")).unwrap();
        write_atomic(&d.join("link.txt"), |w| w.write_all(b"new")).unwrap();
        assert!(std::fs::symlink_metadata(d.join("link.txt"))
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(d.join("real/out.txt")).unwrap(), "new");
        assert_eq!(std::fs::read_dir(d.join("real")).unwrap().count(), 1);
        // A dangling link gets its target created.
        std::os::unix::fs::symlink("real/fresh.txt", d.join("dangling")).unwrap();
        write_atomic(&d.join("dangling"), |w| w.write_all(b"x")).unwrap();
        assert_eq!(std::fs::read_to_string(d.join("real/fresh.txt")).unwrap(), "x");
        // A device node is written through and stays a device node.
        std::os::unix::fs::symlink("/dev/null", d.join("null")).unwrap();
        assert_eq!(
            Destination::resolve(&d.join("null")).unwrap(),
            Destination::Special("/dev/null".into())
        );
        write_atomic(&d.join("null"), |w| w.write_all(b"gone")).unwrap();
        assert!(std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device());
        assert_eq!(Destination::resolve(Path::new("-")).unwrap(), Destination::Stdout);
        assert_eq!(
            Destination::resolve(Path::new("/dev/stdout")).unwrap(),
            Destination::Stdout
        );
        // Folders, missing folders and link loops are refused before anything is written.
        let e = Destination::resolve(&d.join("real")).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        let e = Destination::resolve(&d.join("missing/x.svg"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not exist"), "{e}");
        std::os::unix::fs::symlink("loop", d.join("loop")).unwrap();
        let e = Destination::resolve(&d.join("loop")).unwrap_err().to_string();
        assert!(e.contains("symbolic links"), "{e}");
        // A staged output dropped without a commit leaves nothing.
        let s = Staged::create(&d.join("never.txt")).unwrap();
        // (real, link.txt, dangling, null, loop and the temporary file)
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 6);
        drop(s);
        assert!(!d.join("never.txt").exists());
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 5);
    }
}
