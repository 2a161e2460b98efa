//! Line numbers of a CSV file as an editor shows them, for every error and warning.
//!
//! The `csv` crate's own line count is short after a blank line (it skips the line without
//! counting it) and after a CRLF line ending (it counts a line at each `\n` it consumes, and a
//! record ended by `\r\n` has consumed only the `\r`: rust-csv issue 395). [`Lines`] gives the
//! reader the file with each `\r` of a `\r\n` pair dropped (the reader strips either ending, so
//! the cells are unchanged) and records where every `\n` is; [`Lines::line_at`] turns a
//! record's byte position into its line.

use std::io::{self, BufRead, Read};

/// A reader of `inner` without the `\r` of its `\r\n` pairs (a lone `\r` is kept), which
/// numbers the lines of what it gave out.
pub(super) struct Lines<R> {
    inner: R,
    /// A `\r` read but not yet given out: dropped if a `\n` follows, else given out.
    held_cr: bool,
    /// Bytes given out so far.
    given: u64,
    /// The positions of the `\n` given out, in order.
    newlines: Vec<u64>,
}

impl<R: BufRead> Lines<R> {
    /// Wraps `inner`.
    pub(super) fn new(inner: R) -> Self {
        Lines {
            inner,
            held_cr: false,
            given: 0,
            newlines: Vec::new(),
        }
    }
}

impl<R> Lines<R> {
    /// The line (from 1) of the record the CSV reader says starts at byte `byte`: the reader's
    /// position may sit on the line endings before the record, which are skipped.
    pub(super) fn line_at(&self, byte: u64) -> u64 {
        let mut start = byte;
        while self.newlines.binary_search(&start).is_ok() {
            start += 1;
        }
        1 + self.newlines.partition_point(|&n| n < start) as u64
    }

    /// Counts the bytes just given out (`given`), recording their newlines.
    fn count(&mut self, given: &[u8]) {
        let at = self.given;
        let newlines = given.iter().enumerate().filter(|(_, &b)| b == b'\n');
        self.newlines.extend(newlines.map(|(i, _)| at + i as u64));
        self.given += given.len() as u64;
    }
}

impl<R: BufRead> Read for Lines<R> {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        let mut n = 0;
        while n < out.len() {
            let input = self.inner.fill_buf()?;
            let Some(&first) = input.first() else {
                // The end: a `\r` held at the very end is given out.
                if std::mem::take(&mut self.held_cr) {
                    out[n] = b'\r';
                    self.count(b"\r");
                    n += 1;
                }
                break;
            };
            if std::mem::take(&mut self.held_cr) && first != b'\n' {
                out[n] = b'\r';
                self.count(b"\r");
                n += 1;
                continue;
            }
            // Give out up to the next `\r`, which is held.
            let take = input.len().min(out.len() - n);
            let (given, consumed) = match input[..take].iter().position(|&b| b == b'\r') {
                Some(cr) => (cr, cr + 1),
                None => (take, take),
            };
            out[n..n + given].copy_from_slice(&input[..given]);
            self.inner.consume(consumed);
            self.held_cr = given < consumed;
            self.count(&out[n..n + given]);
            n += given;
            if n > 0 && !self.held_cr {
                break;
            }
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use std::io::{BufReader, Read};

    use super::Lines;

    /// Reads `input` through [`Lines`] with an inner buffer of `capacity` bytes and an outer
    /// one of `chunk` bytes.
    fn through(input: &[u8], capacity: usize, chunk: usize) -> Vec<u8> {
        let mut reader = Lines::new(BufReader::with_capacity(capacity, input));
        let mut all = Vec::new();
        let mut buffer = vec![0; chunk];
        loop {
            let n = reader.read(&mut buffer).unwrap();
            if n == 0 {
                return all;
            }
            all.extend_from_slice(&buffer[..n]);
        }
    }

    #[test]
    fn only_the_carriage_returns_of_crlf_pairs_are_dropped_whatever_the_buffer_sizes() {
        let cases: [(&[u8], &[u8]); 7] = [
            (b"a,b\r\n1,2\r\n", b"a,b\n1,2\n"),
            (b"a,b\n1,2\n", b"a,b\n1,2\n"),
            (b"a\rb\r\n", b"a\rb\n"),
            (b"\r\r\n\r", b"\r\n\r"),
            (b"x\r", b"x\r"),
            (b"\r\n\r\n", b"\n\n"),
            (b"", b""),
        ];
        for (input, expected) in cases {
            for capacity in [1, 2, 3, 64] {
                for chunk in [1, 2, 5, 64] {
                    assert_eq!(
                        through(input, capacity, chunk),
                        expected,
                        "{input:?} with buffers {capacity} and {chunk}"
                    );
                }
            }
        }
    }

    /// The reason for [`Lines`]: the line of each record as an editor numbers it, with LF or
    /// CRLF endings, blank lines before, between and after the records.
    #[test]
    fn records_are_numbered_as_an_editor_numbers_their_lines() {
        let lines = |input: &[u8]| -> Vec<u64> {
            let mut reader =
                csv::Reader::from_reader(Lines::new(BufReader::with_capacity(3, input)));
            let mut record = csv::ByteRecord::new();
            let mut lines = Vec::new();
            while reader.read_byte_record(&mut record).unwrap() {
                let byte = record.position().unwrap().byte();
                lines.push(reader.get_ref().line_at(byte));
            }
            lines
        };
        assert_eq!(lines(b"a,b\n1,2\n\n3,4\n"), [2, 4]);
        assert_eq!(lines(b"a,b\r\n1,2\r\n\r\n3,4\r\n"), [2, 4]);
        assert_eq!(lines(b"\n\na,b\r\n1,2\r\n\r\n\n3,4"), [4, 7]);
        assert_eq!(lines(b"a,b\n1,2\n\n\n"), [2]);
    }
}
