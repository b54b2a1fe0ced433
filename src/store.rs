//! What the board keeps across resets: an uploaded table and the sensor's
//! gauge zero, in two flash areas of their own, through any
//! [`embedded_storage::nor_flash::NorFlash`] (embassy-stm32's flash driver
//! on the board, a RAM sector in host tests and in the virtual board).
//!
//! - **Table area** ([`Layout::table_offset`]): one image
//!   ([`crate::table::image`]). An upload erases the area, writes the
//!   pieces in order and is checked whole at commit (length, CRC-32 over
//!   the image, [`crate::table::Table::verify`]); a refused image is erased
//!   again. At boot the image is read into RAM and checked again; an absent
//!   or damaged one leaves the compiled-in table in use, and the board
//!   says so.
//! - **Zero area** ([`Layout::zero_offset`]): a log of
//!   [`ZERO_RECORD_BYTES`]-byte records `"ZERO" · f32 zero (absolute kPa) ·
//!   CRC-32 of both · 0`, appended one per tare; the last valid one is in
//!   force. When the area is full it is erased and the log starts again.
//!
//! On the NUCLEO-F446RE the areas are sectors 6 and 7 (128 KiB each,
//! `0x0804_0000` and `0x0806_0000`): `src/board/memory.x` gives the linker only the
//! first 256 KiB, so code can never be placed there ([`BOARD_LAYOUT`]).

use embedded_storage::nor_flash::NorFlash;

use crate::protocol::UploadError;
use crate::table::image::{ImageError, TableBuf, HEADER_BYTES, MAX_IMAGE_BYTES};
use crate::table::CHECKSUM_ALGORITHM;

/// Where the two areas are, as offsets into the flash device (bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Start of the table area (erase-block aligned).
    pub table_offset: u32,
    /// Its length (bytes, whole erase blocks).
    pub table_len: u32,
    /// Start of the zero area (erase-block aligned).
    pub zero_offset: u32,
    /// Its length (bytes, whole erase blocks).
    pub zero_len: u32,
}

/// The NUCLEO-F446RE's areas: sectors 6 and 7 of its 512 KiB flash (128
/// KiB each), offsets from the flash base `0x0800_0000` as embassy-stm32's
/// driver takes them.
pub const BOARD_LAYOUT: Layout = Layout {
    table_offset: 0x4_0000,
    table_len: 0x2_0000,
    zero_offset: 0x6_0000,
    zero_len: 0x2_0000,
};

/// Length of one zero record (bytes).
pub const ZERO_RECORD_BYTES: usize = 16;

const ZERO_MAGIC: [u8; 4] = *b"ZERO";

/// Largest write granularity the store supports (bytes): the pieces it
/// writes are padded to the flash's `WRITE_SIZE`, up to this.
pub const MAX_WRITE_SIZE: usize = 16;

/// Why the store failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoreError {
    /// The flash refused an erase, write or read (or its write size is
    /// beyond [`MAX_WRITE_SIZE`]).
    Flash,
}

/// An upload in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Upload {
    len: u32,
    crc32: u32,
    received: u32,
}

/// The store over flash `F`.
#[derive(Debug)]
pub struct Store<F> {
    flash: F,
    layout: Layout,
    upload: Option<Upload>,
    /// Where the next zero record goes (offset inside the zero area).
    zero_next: u32,
}

impl<F: NorFlash> Store<F> {
    /// A store over `flash` with `layout`.
    pub fn new(flash: F, layout: Layout) -> Self {
        Self {
            flash,
            layout,
            upload: None,
            zero_next: 0,
        }
    }

    /// The flash back (tests, a virtual reboot).
    pub fn into_flash(self) -> F {
        self.flash
    }

    /// The stored table, read into RAM and checked.
    pub fn load_table(&mut self) -> Result<TableBuf, ImageError> {
        TableBuf::load(&mut self.flash, self.layout.table_offset)
    }

    /// Begins an upload of `len` bytes whose CRC-32 is `crc32`: erases the
    /// table area (the stored table is gone from here on).
    pub fn begin_upload(&mut self, len: u32, crc32: u32) -> Result<(), UploadError> {
        self.upload = None;
        let fits = len as usize >= HEADER_BYTES
            && len as usize <= MAX_IMAGE_BYTES
            && len <= self.layout.table_len;
        if !fits {
            return Err(UploadError::Length);
        }
        self.erase_table()?;
        self.upload = Some(Upload {
            len,
            crc32,
            received: 0,
        });
        Ok(())
    }

    /// Writes the next piece, which must start where the last one ended.
    pub fn write_chunk(&mut self, offset: u32, data: &[u8]) -> Result<(), UploadError> {
        let mut up = self.upload.ok_or(UploadError::NotStarted)?;
        let end = offset.checked_add(data.len() as u32);
        if offset != up.received || end.is_none_or(|e| e > up.len) {
            return Err(UploadError::Offset);
        }
        let ws = F::WRITE_SIZE;
        if ws == 0 || ws > MAX_WRITE_SIZE || !(offset as usize).is_multiple_of(ws) {
            // Pieces other than the last are whole multiples of the
            // chunk size, which every supported write size divides.
            return Err(UploadError::Flash);
        }
        let mut buf = [0xFFu8; crate::protocol::TABLE_CHUNK_BYTES + MAX_WRITE_SIZE];
        let padded = data.len().div_ceil(ws) * ws;
        let dst = buf.get_mut(..data.len()).ok_or(UploadError::Offset)?;
        dst.copy_from_slice(data);
        let piece = buf.get(..padded).ok_or(UploadError::Offset)?;
        self.flash
            .write(self.layout.table_offset + offset, piece)
            .map_err(|_| UploadError::Flash)?;
        up.received += data.len() as u32;
        self.upload = Some(up);
        Ok(())
    }

    /// Ends the upload: every byte there, the CRC-32 over the image as
    /// announced, and a valid table inside; on any refusal the area is
    /// erased again. Returns the table's checksum.
    pub fn commit_upload(&mut self) -> Result<u32, UploadError> {
        let up = self.upload.take().ok_or(UploadError::NotStarted)?;
        let result = self.check_upload(up);
        if result.is_err() {
            // Leave nothing half-valid behind; boot then uses the
            // compiled-in table.
            self.erase_table()?;
        }
        result
    }

    fn check_upload(&mut self, up: Upload) -> Result<u32, UploadError> {
        if up.received != up.len {
            return Err(UploadError::Incomplete);
        }
        let mut digest = CHECKSUM_ALGORITHM.digest();
        let mut buf = [0u8; 64];
        let mut at = 0u32;
        while at < up.len {
            let n = (up.len - at).min(buf.len() as u32) as usize;
            let piece = buf.get_mut(..n).ok_or(UploadError::Flash)?;
            self.flash
                .read(self.layout.table_offset + at, piece)
                .map_err(|_| UploadError::Flash)?;
            digest.update(piece);
            at += n as u32;
        }
        if digest.finalize() != up.crc32 {
            return Err(UploadError::Crc);
        }
        let table = self.load_table().map_err(UploadError::Image)?;
        Ok(table.table().checksum)
    }

    fn erase_table(&mut self) -> Result<(), UploadError> {
        let from = self.layout.table_offset;
        self.flash
            .erase(from, from + self.layout.table_len)
            .map_err(|_| UploadError::Flash)
    }

    /// The gauge zero in force (absolute kPa): the last valid record of
    /// the zero area, or `None`. Also finds where the next record goes.
    pub fn load_zero(&mut self) -> Result<Option<f32>, StoreError> {
        let mut last = None;
        let mut at = 0u32;
        self.zero_next = self.layout.zero_len;
        while at + ZERO_RECORD_BYTES as u32 <= self.layout.zero_len {
            let mut rec = [0u8; ZERO_RECORD_BYTES];
            self.flash
                .read(self.layout.zero_offset + at, &mut rec)
                .map_err(|_| StoreError::Flash)?;
            if rec.iter().all(|&b| b == 0xFF) {
                self.zero_next = at;
                break;
            }
            if let Some(z) = parse_zero(&rec) {
                last = Some(z);
            }
            at += ZERO_RECORD_BYTES as u32;
        }
        Ok(last)
    }

    /// Appends a record making `zero_kpa` the zero in force (erasing the
    /// area first when it is full).
    pub fn save_zero(&mut self, zero_kpa: f32) -> Result<(), StoreError> {
        self.load_zero()?;
        if self.zero_next + ZERO_RECORD_BYTES as u32 > self.layout.zero_len {
            let from = self.layout.zero_offset;
            self.flash
                .erase(from, from + self.layout.zero_len)
                .map_err(|_| StoreError::Flash)?;
            self.zero_next = 0;
        }
        let mut rec = [0u8; ZERO_RECORD_BYTES];
        rec[0..4].copy_from_slice(&ZERO_MAGIC);
        rec[4..8].copy_from_slice(&zero_kpa.to_bits().to_le_bytes());
        let crc = CHECKSUM_ALGORITHM.checksum(&rec[0..8]);
        rec[8..12].copy_from_slice(&crc.to_le_bytes());
        self.flash
            .write(self.layout.zero_offset + self.zero_next, &rec)
            .map_err(|_| StoreError::Flash)?;
        self.zero_next += ZERO_RECORD_BYTES as u32;
        match self.load_zero()? {
            Some(z) if z.to_bits() == zero_kpa.to_bits() => Ok(()),
            _ => Err(StoreError::Flash),
        }
    }
}

fn parse_zero(rec: &[u8; ZERO_RECORD_BYTES]) -> Option<f32> {
    let mut crc = [0u8; 4];
    crc.copy_from_slice(&rec[8..12]);
    if rec[0..4] != ZERO_MAGIC || CHECKSUM_ALGORITHM.checksum(&rec[0..8]) != u32::from_le_bytes(crc)
    {
        return None;
    }
    let mut bits = [0u8; 4];
    bits.copy_from_slice(&rec[4..8]);
    Some(f32::from_bits(u32::from_le_bytes(bits)))
}

/// A flash sector in RAM that behaves like NOR flash: erase sets bytes to
/// 0xFF, a write can only clear bits and is refused over bytes not erased,
/// operations must be aligned. The host tests' and the virtual board's
/// flash.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RamFlash<const N: usize, const ERASE: usize> {
    /// The bytes.
    pub bytes: [u8; N],
    /// Erases so far (tests count wear).
    pub erases: u32,
}

impl<const N: usize, const ERASE: usize> RamFlash<N, ERASE> {
    /// An erased device.
    pub const fn new() -> Self {
        Self {
            bytes: [0xFF; N],
            erases: 0,
        }
    }
}

impl<const N: usize, const ERASE: usize> Default for RamFlash<N, ERASE> {
    fn default() -> Self {
        Self::new()
    }
}

/// What [`RamFlash`] refuses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RamFlashError {
    /// Out of the device.
    OutOfBounds,
    /// Not aligned to the read/write/erase size.
    NotAligned,
    /// A write over bytes that were not erased.
    NotErased,
}

impl embedded_storage::nor_flash::NorFlashError for RamFlashError {
    fn kind(&self) -> embedded_storage::nor_flash::NorFlashErrorKind {
        use embedded_storage::nor_flash::NorFlashErrorKind as K;
        match self {
            RamFlashError::OutOfBounds => K::OutOfBounds,
            RamFlashError::NotAligned => K::NotAligned,
            RamFlashError::NotErased => K::Other,
        }
    }
}

impl<const N: usize, const ERASE: usize> embedded_storage::nor_flash::ErrorType
    for RamFlash<N, ERASE>
{
    type Error = RamFlashError;
}

impl<const N: usize, const ERASE: usize> embedded_storage::nor_flash::ReadNorFlash
    for RamFlash<N, ERASE>
{
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), RamFlashError> {
        let at = offset as usize;
        let src = self
            .bytes
            .get(at..at + bytes.len())
            .ok_or(RamFlashError::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        N
    }
}

impl<const N: usize, const ERASE: usize> NorFlash for RamFlash<N, ERASE> {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = ERASE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), RamFlashError> {
        let (from, to) = (from as usize, to as usize);
        if !from.is_multiple_of(ERASE) || !to.is_multiple_of(ERASE) || from > to {
            return Err(RamFlashError::NotAligned);
        }
        self.bytes
            .get_mut(from..to)
            .ok_or(RamFlashError::OutOfBounds)?
            .fill(0xFF);
        self.erases += 1;
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), RamFlashError> {
        let at = offset as usize;
        if !at.is_multiple_of(Self::WRITE_SIZE) || !bytes.len().is_multiple_of(Self::WRITE_SIZE) {
            return Err(RamFlashError::NotAligned);
        }
        let dst = self
            .bytes
            .get_mut(at..at + bytes.len())
            .ok_or(RamFlashError::OutOfBounds)?;
        if dst.iter().any(|&b| b != 0xFF) {
            return Err(RamFlashError::NotErased);
        }
        dst.copy_from_slice(bytes);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::generated::TABLE;
    use crate::table::image::write_image;

    type Flash = RamFlash<8192, 2048>;
    const LAYOUT: Layout = Layout {
        table_offset: 0,
        table_len: 4096,
        zero_offset: 4096,
        zero_len: 2048,
    };

    fn image() -> std::vec::Vec<u8> {
        let mut v = std::vec::Vec::new();
        write_image(&TABLE, &mut |b| v.extend_from_slice(b));
        v
    }

    fn upload(store: &mut Store<Flash>, bytes: &[u8], crc32: u32) -> Result<u32, UploadError> {
        store.begin_upload(bytes.len() as u32, crc32)?;
        for (k, piece) in bytes.chunks(crate::protocol::TABLE_CHUNK_BYTES).enumerate() {
            store.write_chunk((k * crate::protocol::TABLE_CHUNK_BYTES) as u32, piece)?;
        }
        store.commit_upload()
    }

    #[test]
    fn empty_flash_has_no_table_and_no_zero() {
        let mut store = Store::new(Flash::new(), LAYOUT);
        assert_eq!(store.load_table().map(|_| ()), Err(ImageError::Absent));
        assert_eq!(store.load_zero(), Ok(None));
    }

    #[test]
    fn uploaded_table_survives_a_reboot() {
        let bytes = image();
        let crc = CHECKSUM_ALGORITHM.checksum(&bytes);
        let mut store = Store::new(Flash::new(), LAYOUT);
        assert_eq!(upload(&mut store, &bytes, crc), Ok(TABLE.checksum));
        let mut store = Store::new(store.into_flash(), LAYOUT);
        let buf = store.load_table().unwrap();
        assert_eq!(buf.table(), TABLE);
    }

    #[test]
    fn damaged_uploads_are_refused_and_erased() {
        let bytes = image();
        let crc = CHECKSUM_ALGORITHM.checksum(&bytes);
        let mut store = Store::new(Flash::new(), LAYOUT);
        // Transfer damage: the CRC over the image differs.
        let mut hit = bytes.clone();
        hit[100] ^= 0x40;
        assert_eq!(upload(&mut store, &hit, crc), Err(UploadError::Crc));
        assert_eq!(store.load_table().map(|_| ()), Err(ImageError::Absent));
        // A table whose own checksum fails, sent intact.
        let crc_hit = CHECKSUM_ALGORITHM.checksum(&hit);
        assert_eq!(
            upload(&mut store, &hit, crc_hit),
            Err(UploadError::Image(ImageError::Table(
                crate::table::TableError::Checksum
            )))
        );
        assert_eq!(store.load_table().map(|_| ()), Err(ImageError::Absent));
        // Out of order, too long, missing pieces, no begin.
        store.begin_upload(bytes.len() as u32, crc).unwrap();
        assert_eq!(store.write_chunk(4, &bytes[4..8]), Err(UploadError::Offset));
        assert_eq!(store.commit_upload(), Err(UploadError::Incomplete));
        assert_eq!(store.commit_upload(), Err(UploadError::NotStarted));
        assert_eq!(
            store.write_chunk(0, &bytes[..4]),
            Err(UploadError::NotStarted)
        );
        assert_eq!(store.begin_upload(8, 0), Err(UploadError::Length));
        assert_eq!(store.begin_upload(5000, 0), Err(UploadError::Length));
    }

    #[test]
    fn zero_log_keeps_the_last_and_wraps() {
        let mut store = Store::new(Flash::new(), LAYOUT);
        for k in 0..300 {
            store.save_zero(100.0 + k as f32 * 0.01).unwrap();
        }
        let mut store = Store::new(store.into_flash(), LAYOUT);
        assert_eq!(store.load_zero(), Ok(Some(100.0 + 299.0 * 0.01)));
        // 2048 / 16 = 128 records per erase: 300 records took two erases.
        assert_eq!(store.into_flash().erases, 2);
    }
}
