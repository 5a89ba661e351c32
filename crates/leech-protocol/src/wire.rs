//! Little-endian fixed-width fields, written and read in order.
//!
//! Both sides check a body's length before touching its fields (the writer
//! against its buffer, the reader against the type's fixed length), so the
//! fallbacks here (a write past the end is dropped, a read past the end
//! gives zeros) are never reached; they exist so that no input can make
//! the crate panic.

/// Writes fields one after another into a buffer.
pub(crate) struct Writer<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl<'a> Writer<'a> {
    pub(crate) fn new(out: &'a mut [u8]) -> Writer<'a> {
        Writer { out, at: 0 }
    }

    /// Bytes written so far.
    pub(crate) fn len(&self) -> usize {
        self.at
    }

    fn put<const N: usize>(&mut self, bytes: [u8; N]) {
        for byte in bytes {
            if let Some(slot) = self.out.get_mut(self.at) {
                *slot = byte;
            }
            self.at += 1;
        }
    }

    pub(crate) fn u8(&mut self, v: u8) {
        self.put([v]);
    }

    pub(crate) fn u16(&mut self, v: u16) {
        self.put(v.to_le_bytes());
    }

    pub(crate) fn i16(&mut self, v: i16) {
        self.put(v.to_le_bytes());
    }

    pub(crate) fn u32(&mut self, v: u32) {
        self.put(v.to_le_bytes());
    }

    pub(crate) fn i32(&mut self, v: i32) {
        self.put(v.to_le_bytes());
    }
}

/// Reads fields one after another from a body, tracking their offsets.
pub(crate) struct Reader<'a> {
    rest: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Reader<'a> {
        Reader { rest: bytes, at: 0 }
    }

    /// The offset of the next field in the body.
    pub(crate) fn offset(&self) -> usize {
        self.at
    }

    fn take<const N: usize>(&mut self) -> [u8; N] {
        self.at += N;
        match self.rest.split_first_chunk::<N>() {
            Some((head, tail)) => {
                self.rest = tail;
                *head
            }
            None => [0; N],
        }
    }

    pub(crate) fn u8(&mut self) -> u8 {
        let [v] = self.take();
        v
    }

    pub(crate) fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }

    pub(crate) fn i16(&mut self) -> i16 {
        i16::from_le_bytes(self.take())
    }

    pub(crate) fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }

    pub(crate) fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
}
