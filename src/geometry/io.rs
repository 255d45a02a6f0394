//! Text-file plumbing shared by the readers and writers: atomic writes, UTF-8 loading, line
//! splitting, field tokenising and strict number parsing.

use crate::error::{Error, Result};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Longest excerpt of an offending line quoted in an error message, in characters.
const EXCERPT: usize = 48;

/// Write `path` atomically: `fill` writes into a buffered temporary file in the same directory,
/// which is flushed, synced and then renamed over `path`.
///
/// Whatever happens (an error from `fill`, a full disk, a crash), `path` holds either its old
/// contents or the complete new ones, never a half-written file; the temporary file is removed
/// on failure.
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
{
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| Error::invalid(format!("{}: not a file name", path.display())))?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // A name no other writer (thread or process) uses; `create_new` refuses to reuse one.
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
    let mut w = BufWriter::with_capacity(1 << 16, file);
    let written = fill(&mut w)
        .and_then(|()| w.flush())
        .and_then(|()| w.get_ref().sync_all())
        .and_then(|()| std::fs::rename(&tmp, path));
    if let Err(e) = written {
        // Best effort: the temporary file is ours and useless now.
        let _ = std::fs::remove_file(&tmp);
        return Err(io(e));
    }
    Ok(())
}

/// Read a whole file as UTF-8 text (a leading byte-order mark is dropped).
pub(crate) fn read_text(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    text_from_bytes(bytes, path)
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
                message: "not UTF-8 text (a binary file?)".into(),
            })
        }
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
}
