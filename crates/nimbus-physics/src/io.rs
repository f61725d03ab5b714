//! Bounded reads of the files nimbus is given (scenes, meshes, wind fields,
//! roots and hierarchies, caches).
//!
//! Every such file is checked before a byte of it is read: it must be a
//! regular file (a FIFO would block the reader forever, `/dev/zero` never
//! ends, a directory has no content) no larger than the limit its format
//! documents, and it is then read through a reader that stops one byte past
//! that limit, so a file that grows while it is read cannot make the
//! process use more memory than the limit either.

use std::fs::{File, Metadata};
use std::io::Read;
use std::path::Path;

/// The 64-bit FNV-1a hash of `text` (Fowler, Noll & Vo): the name of a
/// cache file from the description of what it holds, stable across builds
/// and platforms (unlike `std`'s hasher).
pub fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Why a file was not read. Displayed without the path, which the caller's
/// message names (with the key or flag that gave it).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ReadError {
    /// The operating system refused (no such file, permissions, …).
    #[error("cannot read: {0}")]
    Io(String),
    /// A FIFO, device, socket or directory.
    #[error("is {0}, not a regular file")]
    NotRegular(&'static str),
    /// Larger than the format's limit.
    #[error("is {bytes} bytes ({}); at most {} are read", human_bytes(*bytes), human_bytes(*max))]
    TooLarge {
        /// Its size (or, for a file that grew while it was read, the bytes
        /// read before stopping).
        bytes: u64,
        /// The limit.
        max: u64,
    },
    /// Not UTF-8 text (for [`read_text_bounded`]).
    #[error("is not UTF-8 text (byte {0})")]
    NotText(usize),
}

/// What kind of non-regular file `metadata` describes.
fn kind_of(metadata: &Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = metadata.file_type();
        if t.is_fifo() {
            return "a named pipe (FIFO)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if metadata.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

/// Checks that `path` is a regular file (symbolic links followed) of at
/// most `max_bytes`, without opening it; returns its size.
pub fn check_regular_file(path: &Path, max_bytes: u64) -> Result<u64, ReadError> {
    let metadata = std::fs::metadata(path).map_err(|e| ReadError::Io(e.to_string()))?;
    if !metadata.is_file() {
        return Err(ReadError::NotRegular(kind_of(&metadata)));
    }
    if metadata.len() > max_bytes {
        return Err(ReadError::TooLarge {
            bytes: metadata.len(),
            max: max_bytes,
        });
    }
    Ok(metadata.len())
}

/// The bytes of `path`, a regular file of at most `max_bytes`: checked by
/// its metadata before it is opened (so a FIFO is never opened and cannot
/// block), then read through a reader that stops one byte past the limit.
pub fn read_bounded(path: &Path, max_bytes: u64) -> Result<Vec<u8>, ReadError> {
    let expected = check_regular_file(path, max_bytes)?;
    let file = File::open(path).map_err(|e| ReadError::Io(e.to_string()))?;
    // The file may have been replaced between the check and the open.
    let metadata = file.metadata().map_err(|e| ReadError::Io(e.to_string()))?;
    if !metadata.is_file() {
        return Err(ReadError::NotRegular(kind_of(&metadata)));
    }
    let capacity = usize::try_from(expected.min(max_bytes)).unwrap_or(0);
    let mut bytes = Vec::with_capacity(capacity);
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| ReadError::Io(e.to_string()))?;
    if bytes.len() as u64 > max_bytes {
        return Err(ReadError::TooLarge {
            bytes: bytes.len() as u64,
            max: max_bytes,
        });
    }
    Ok(bytes)
}

/// [`read_bounded`] of a UTF-8 text file.
pub fn read_text_bounded(path: &Path, max_bytes: u64) -> Result<String, ReadError> {
    String::from_utf8(read_bounded(path, max_bytes)?)
        .map_err(|e| ReadError::NotText(e.utf8_error().valid_up_to()))
}

/// A byte count for people: "512 MiB", "3.0 GiB", "17 bytes".
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    if bytes < 1024 {
        return format!("{bytes} bytes");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if value.fract() == 0.0 {
        format!("{value} {}", UNITS[unit])
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

/// Most characters of a value taken from a file that an error line shows.
pub const MAX_SHOWN_CHARS: usize = 64;

/// Whether `c` reorders or hides text on a terminal: controls, and the
/// Unicode bidirectional formatting characters (UAX #9) and other
/// invisible format characters (general category Cf).
fn is_unsafe_to_print(c: char) -> bool {
    c.is_control()
        || matches!(c,
            '\u{061c}' | '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}'
            | '\u{2060}'..='\u{2069}' | '\u{feff}')
}

/// `text` (taken from a file) as an error line shows it: characters that
/// would act on the terminal escaped (`\u{202e}`, `\n`), and at most
/// `max_chars` characters shown, escapes counted as they are printed, the
/// rest counted, so that an error stays one line of bounded length
/// whatever the file holds.
pub fn shown_text(text: &str, max_chars: usize) -> String {
    let mut out = String::new();
    let mut shown_chars = 0usize;
    for c in text.chars() {
        let escaped: String = if is_unsafe_to_print(c) {
            c.escape_default().collect()
        } else {
            c.to_string()
        };
        let width = escaped.chars().count();
        if shown_chars + width > max_chars {
            out.push_str(&format!("… ({} characters)", text.chars().count()));
            break;
        }
        shown_chars += width;
        out.push_str(&escaped);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published FNV-1a 64 test vectors: cache names computed by other
    /// builds stay valid.
    #[test]
    fn fnv1a_matches_the_reference_vectors() {
        assert_eq!(fnv1a(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a("a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a("foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn file_text_is_shown_on_one_bounded_line() {
        assert_eq!(shown_text("plain", 64), "plain");
        assert_eq!(shown_text("a\nb\u{202e}", 64), "a\\nb\\u{202e}");
        assert_eq!(shown_text("abcdef", 3), "abc… (6 characters)");
        // Escapes count as printed: 100 DEL characters stay within the bound.
        let shown = shown_text(&"\u{7f}".repeat(100), 64);
        assert!(shown.chars().count() <= 64 + 20, "{shown}");
        assert!(!shown.contains('\u{7f}') && shown.ends_with("(100 characters)"));
    }
    use std::io::Write;

    fn temp(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("nimbus-io-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        dir
    }

    #[test]
    fn regular_files_within_the_limit_are_read() {
        let path = temp("ok").join("a.bin");
        std::fs::write(&path, b"hello").expect("write");
        assert_eq!(read_bounded(&path, 5).expect("read"), b"hello");
        assert_eq!(
            read_bounded(&path, 4),
            Err(ReadError::TooLarge { bytes: 5, max: 4 })
        );
        assert_eq!(read_text_bounded(&path, 5).expect("text"), "hello");
        let mut file = std::fs::File::create(&path).expect("create");
        file.write_all(&[b'a', 0xff]).expect("write");
        drop(file);
        assert_eq!(read_text_bounded(&path, 5), Err(ReadError::NotText(1)));
    }

    #[test]
    fn devices_directories_and_missing_files_are_refused_without_reading() {
        let dir = temp("dir");
        assert_eq!(
            read_bounded(&dir, 1 << 20),
            Err(ReadError::NotRegular("a directory"))
        );
        #[cfg(unix)]
        {
            // /dev/zero has length 0 and never ends: refused by its type.
            let e = read_bounded(Path::new("/dev/zero"), 1 << 20).expect_err("device");
            assert_eq!(e, ReadError::NotRegular("a character device"));
            assert_eq!(e.to_string(), "is a character device, not a regular file");
        }
        let missing = read_bounded(&dir.join("missing"), 10).expect_err("missing");
        assert!(matches!(missing, ReadError::Io(_)), "{missing}");
    }

    #[test]
    fn sizes_read_as_people_write_them() {
        assert_eq!(human_bytes(17), "17 bytes");
        assert_eq!(human_bytes(512 * 1024 * 1024), "512 MiB");
        assert_eq!(
            human_bytes(3 * 1024 * 1024 * 1024 + 1024 * 1024 * 100),
            "3.1 GiB"
        );
        assert_eq!(
            ReadError::TooLarge {
                bytes: 2048,
                max: 1024
            }
            .to_string(),
            "is 2048 bytes (2 KiB); at most 1 KiB are read"
        );
    }
}
