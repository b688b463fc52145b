//! Standard output with every write checked: a closed pipe (`… | head`) or a full disk
//! (`… > /dev/full`) becomes a [`AppError::Stdout`] instead of a panic in `println!`.

use std::io::{BufWriter, Write};

use super::AppError;

/// Buffered, checked standard output for the data a command prints.
pub struct StdoutWriter {
    inner: BufWriter<std::io::StdoutLock<'static>>,
}

impl Default for StdoutWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl StdoutWriter {
    /// Locks standard output for the life of the writer.
    pub fn new() -> Self {
        StdoutWriter {
            inner: BufWriter::new(std::io::stdout().lock()),
        }
    }

    /// Writes `text` as is.
    pub fn text(&mut self, text: &str) -> Result<(), AppError> {
        self.inner
            .write_all(text.as_bytes())
            .map_err(AppError::Stdout)
    }

    /// Writes `line` and a newline.
    pub fn line(&mut self, line: &str) -> Result<(), AppError> {
        self.text(line)?;
        self.text("\n")
    }

    /// Flushes; call it once at the end (a dropped writer's flush error would be lost).
    pub fn finish(mut self) -> Result<(), AppError> {
        self.inner.flush().map_err(AppError::Stdout)
    }
}

impl Write for StdoutWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.inner.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Prints `text` and flushes, checked.
pub fn print_text(text: &str) -> Result<(), AppError> {
    let mut out = StdoutWriter::new();
    out.text(text)?;
    out.finish()
}

/// Prints each line and flushes, checked.
pub fn print_lines<I: IntoIterator<Item = S>, S: AsRef<str>>(lines: I) -> Result<(), AppError> {
    let mut out = StdoutWriter::new();
    for l in lines {
        out.line(l.as_ref())?;
    }
    out.finish()
}
