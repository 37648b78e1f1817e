//! A streaming deframer shared by the serial protocols: it finds frames in a byte stream by a
//! two-byte sync and a length field, checks them, and resynchronises after garbage, impossible
//! lengths or bad checksums by scanning for the next sync.
//!
//! The buffer is bounded by the protocol's largest legal frame: a length field beyond it is
//! treated as garbage rather than waited for, so a corrupt header never stalls the stream.

/// How one protocol lays out its frames; the [`Deframer`] does the rest.
pub trait Framing {
    /// The two bytes every frame starts with.
    fn sync(&self) -> [u8; 2];
    /// Bytes needed (sync included) before [`Framing::frame_len`] can be asked.
    fn header_len(&self) -> usize;
    /// The largest legal frame, in bytes: the deframer never buffers more.
    fn max_frame_len(&self) -> usize;
    /// The whole frame's length from its first `header_len` bytes, or `None` when the
    /// length field is impossible (too large or too small).
    fn frame_len(&self, header: &[u8]) -> Option<usize>;
    /// Checks a complete frame (its trailer and checksum).
    fn check(&self, frame: &[u8]) -> Result<(), FrameFault>;
}

/// Why a complete frame was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameFault {
    /// The CRC or checksum does not match the bytes.
    Checksum,
    /// The bytes after the data are not the protocol's end marker.
    Trailer,
}

/// Counters of what the deframer saw, for health reporting (error rates).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DeframerStats {
    /// Bytes discarded while looking for a frame: garbage, and the bytes of rejected frames.
    pub bytes_skipped: u64,
    /// Candidate frames whose length field was impossible.
    pub length_errors: u64,
    /// Complete candidate frames with a bad CRC or checksum.
    pub checksum_errors: u64,
    /// Complete candidate frames without the end marker.
    pub trailer_errors: u64,
    /// Frames accepted.
    pub frames_ok: u64,
}

/// Finds the frames of one protocol in a stream of bytes arriving in arbitrary pieces.
#[derive(Debug, Clone)]
pub struct Deframer<F> {
    framing: F,
    buffer: Vec<u8>,
    stats: DeframerStats,
}

impl<F: Framing> Deframer<F> {
    /// A deframer with an empty buffer and zero counters.
    pub fn new(framing: F) -> Self {
        let capacity = framing.max_frame_len();
        Self {
            framing,
            buffer: Vec::with_capacity(capacity),
            stats: DeframerStats::default(),
        }
    }

    /// Takes the next bytes of the stream and returns the complete, checked frames they finish,
    /// in order, each exactly as on the wire (sync to end). Partial frames stay buffered.
    pub fn push(&mut self, mut input: &[u8]) -> Vec<Vec<u8>> {
        let mut frames = Vec::new();
        while let Some(frame) = self.next_frame(&mut input) {
            frames.push(frame);
        }
        frames
    }

    /// The counters so far.
    pub fn stats(&self) -> DeframerStats {
        self.stats
    }

    /// Bytes held while waiting for the rest of a frame.
    pub fn buffered_len(&self) -> usize {
        self.buffer.len()
    }

    /// Drops any partial frame, counting its bytes as skipped (e.g. after a baud-rate change).
    pub fn reset(&mut self) {
        self.skip(self.buffer.len());
    }

    /// The framing rules this deframer applies.
    pub fn framing(&self) -> &F {
        &self.framing
    }

    fn skip(&mut self, count: usize) {
        self.stats.bytes_skipped += count as u64;
        self.buffer.drain(..count);
    }

    /// Moves bytes from `input` into the buffer as needed and returns the next frame, or
    /// `None` once `input` is exhausted without completing one.
    fn next_frame(&mut self, input: &mut &[u8]) -> Option<Vec<u8>> {
        let sync = self.framing.sync();
        let header_len = self.framing.header_len();
        let capacity = self.framing.max_frame_len();
        loop {
            self.discard_until_sync(sync);
            if self.buffer.len() >= header_len {
                match self.framing.frame_len(&self.buffer[..header_len]) {
                    Some(len) if len <= capacity && len >= header_len => {
                        if self.buffer.len() >= len {
                            match self.framing.check(&self.buffer[..len]) {
                                Ok(()) => {
                                    self.stats.frames_ok += 1;
                                    return Some(self.buffer.drain(..len).collect());
                                }
                                Err(fault) => {
                                    match fault {
                                        FrameFault::Checksum => self.stats.checksum_errors += 1,
                                        FrameFault::Trailer => self.stats.trailer_errors += 1,
                                    }
                                    // Only the sync is dropped: a real frame may start inside
                                    // the rejected one.
                                    self.skip(1);
                                    continue;
                                }
                            }
                        }
                    }
                    _ => {
                        self.stats.length_errors += 1;
                        self.skip(1);
                        continue;
                    }
                }
            }
            if input.is_empty() {
                return None;
            }
            let take = input.len().min(capacity - self.buffer.len());
            self.buffer.extend_from_slice(&input[..take]);
            *input = &input[take..];
        }
    }

    /// Drops the bytes before the first sync; keeps a trailing first sync byte, which may be
    /// completed by the next input.
    fn discard_until_sync(&mut self, sync: [u8; 2]) {
        let found = self.buffer.windows(2).position(|pair| pair == sync);
        let keep_from = match found {
            Some(position) => position,
            None if self.buffer.last() == Some(&sync[0]) => self.buffer.len() - 1,
            None => self.buffer.len(),
        };
        if keep_from > 0 {
            self.skip(keep_from);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A toy framing: `AA 55 len payload[len] xor`, payloads of at most 8 bytes.
    struct Toy;

    impl Framing for Toy {
        fn sync(&self) -> [u8; 2] {
            [0xAA, 0x55]
        }
        fn header_len(&self) -> usize {
            3
        }
        fn max_frame_len(&self) -> usize {
            12
        }
        fn frame_len(&self, header: &[u8]) -> Option<usize> {
            let len = usize::from(header[2]);
            (len <= 8).then_some(len + 4)
        }
        fn check(&self, frame: &[u8]) -> Result<(), FrameFault> {
            let (body, chk) = frame.split_at(frame.len() - 1);
            let xor = body[3..].iter().fold(0, |acc, byte| acc ^ byte);
            if xor == chk[0] {
                Ok(())
            } else {
                Err(FrameFault::Checksum)
            }
        }
    }

    fn toy(payload: &[u8]) -> Vec<u8> {
        let mut frame = vec![0xAA, 0x55, payload.len() as u8];
        frame.extend_from_slice(payload);
        frame.push(payload.iter().fold(0, |acc, byte| acc ^ byte));
        frame
    }

    #[test]
    fn garbage_before_a_frame_is_skipped_and_counted() {
        let mut deframer = Deframer::new(Toy);
        let mut stream = vec![1, 2, 0xAA, 3];
        stream.extend(toy(&[7, 8]));
        assert_eq!(deframer.push(&stream), vec![toy(&[7, 8])]);
        let stats = deframer.stats();
        assert_eq!(stats.bytes_skipped, 4);
        assert_eq!(stats.frames_ok, 1);
    }

    #[test]
    fn an_impossible_length_is_garbage_and_the_next_frame_is_found() {
        let mut deframer = Deframer::new(Toy);
        let mut stream = vec![0xAA, 0x55, 200];
        stream.extend(toy(&[1]));
        assert_eq!(deframer.push(&stream), vec![toy(&[1])]);
        assert_eq!(deframer.stats().length_errors, 1);
        assert_eq!(deframer.stats().bytes_skipped, 3);
    }

    #[test]
    fn a_frame_starting_inside_a_rejected_one_is_found() {
        let mut deframer = Deframer::new(Toy);
        // A false header claims 4 bytes, which swallow the start of a real frame.
        let mut stream = vec![0xAA, 0x55, 4];
        stream.extend(toy(&[9]));
        assert_eq!(deframer.push(&stream), vec![toy(&[9])]);
        assert_eq!(deframer.stats().checksum_errors, 1);
    }

    #[test]
    fn a_sync_byte_at_the_end_of_a_read_is_kept_for_the_next_read() {
        let mut deframer = Deframer::new(Toy);
        let frame = toy(&[5, 6, 7]);
        assert!(deframer.push(&[0, 0xAA]).is_empty());
        assert_eq!(deframer.buffered_len(), 1);
        assert_eq!(deframer.push(&frame[1..]), vec![frame]);
        assert_eq!(deframer.stats().bytes_skipped, 1);
    }

    #[test]
    fn the_buffer_never_exceeds_the_largest_frame() {
        let mut deframer = Deframer::new(Toy);
        let stream: Vec<u8> = (0..1000)
            .map(|i| if i % 2 == 0 { 0xAA } else { 0x55 })
            .collect();
        assert!(deframer.push(&stream).is_empty());
        assert!(deframer.buffered_len() <= 12);
    }

    #[test]
    fn reset_drops_a_partial_frame() {
        let mut deframer = Deframer::new(Toy);
        let frame = toy(&[1, 2, 3]);
        assert!(deframer.push(&frame[..4]).is_empty());
        deframer.reset();
        assert_eq!(deframer.buffered_len(), 0);
        assert_eq!(deframer.stats().bytes_skipped, 4);
        assert_eq!(deframer.push(&frame), vec![frame]);
    }
}
