//! The table as a byte image: what `host-sim tables --image` writes, what
//! the host link uploads ([`crate::protocol::HostCommand::TableBegin`]) and
//! what the board keeps in its table flash sector ([`crate::store`]).
//!
//! # Format (little-endian), version [`IMAGE_VERSION`]
//!
//! ```text
//! offset  size  field
//!      0     4  magic "URTB"
//!      4     2  image version (IMAGE_VERSION)
//!      6     2  table format version (table::FORMAT_VERSION)
//!      8     1  flags: bit 0 = placeholder; other bits 0
//!      9     3  zero
//!     12     2  depths nd (2..=MAX_POINTS)
//!     14     2  diameters np (2..=MAX_POINTS)
//!     16     4  initial_diameter_mm  f32
//!     20     4  expansion_length_mm  f32
//!     24     4  skin_thickness_mm    f32
//!     28     4  table checksum (Table::compute_checksum)
//!     32  4·nd  depths_mm             f32 each
//!      …  4·np  diameters_mm          f32 each
//!      …  4·nd·np pressure_kpa        f32 each, row-major [depth][diameter]
//! ```
//!
//! The image carries the table's own CRC-32 ([`Table::checksum`], over its
//! contents); an upload adds a CRC-32 over the whole image for the
//! transfer. The firmware copies an image into a [`TableBuf`] in RAM (at
//! most [`MAX_IMAGE_VALUES`] numbers) and checks it with [`Table::verify`]
//! before using it.

use embedded_storage::nor_flash::ReadNorFlash;
use serde::{Deserialize, Serialize};

use super::{Table, TableError, MAX_POINTS};

/// Image magic.
pub const IMAGE_MAGIC: [u8; 4] = *b"URTB";
/// Version of the image layout above.
pub const IMAGE_VERSION: u16 = 1;
/// Header length (bytes).
pub const HEADER_BYTES: usize = 32;
/// Most numbers (depths + diameters + pressures) an image may hold: what
/// the firmware reserves in RAM for an uploaded table (4 bytes each).
pub const MAX_IMAGE_VALUES: usize = 768;
/// Longest image (bytes).
pub const MAX_IMAGE_BYTES: usize = HEADER_BYTES + 4 * MAX_IMAGE_VALUES;

/// Why an image was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ImageError {
    /// Erased flash: no image was ever stored.
    Absent,
    /// Not an image (magic), or another image version.
    Header,
    /// Dimensions out of range, more than [`MAX_IMAGE_VALUES`] numbers, or
    /// a length that does not match them.
    Size,
    /// The flash could not be read.
    Read,
    /// The table inside failed [`Table::verify`].
    Table(TableError),
}

/// Length (bytes) of the image of a table with `nd` depths and `np`
/// diameters.
pub const fn image_len(nd: usize, np: usize) -> usize {
    HEADER_BYTES + 4 * (nd + np + nd * np)
}

/// Writes the image of `table` through `out`, piece by piece (a host tool
/// collects it into a file; the format above).
pub fn write_image(table: &Table<'_>, out: &mut impl FnMut(&[u8])) {
    out(&IMAGE_MAGIC);
    out(&IMAGE_VERSION.to_le_bytes());
    out(&table.format_version.to_le_bytes());
    out(&[u8::from(table.placeholder), 0, 0, 0]);
    // Axis lengths beyond u16 fail the size check when read back.
    out(&(table.depths_mm.len() as u16).to_le_bytes());
    out(&(table.diameters_mm.len() as u16).to_le_bytes());
    for v in [
        table.initial_diameter_mm,
        table.expansion_length_mm,
        table.skin_thickness_mm,
    ] {
        out(&v.to_le_bytes());
    }
    out(&table.checksum.to_le_bytes());
    for axis in [table.depths_mm, table.diameters_mm, table.pressure_kpa] {
        for v in axis {
            out(&v.to_le_bytes());
        }
    }
}

/// The fixed part of an image, read from its header.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Header {
    format_version: u16,
    placeholder: bool,
    nd: usize,
    np: usize,
    initial_diameter_mm: f32,
    expansion_length_mm: f32,
    skin_thickness_mm: f32,
    checksum: u32,
}

fn le_u16(b: &[u8], at: usize) -> u16 {
    let mut a = [0u8; 2];
    if let Some(s) = b.get(at..at + 2) {
        a.copy_from_slice(s);
    }
    u16::from_le_bytes(a)
}

fn le_u32(b: &[u8], at: usize) -> u32 {
    let mut a = [0u8; 4];
    if let Some(s) = b.get(at..at + 4) {
        a.copy_from_slice(s);
    }
    u32::from_le_bytes(a)
}

fn parse_header(h: &[u8; HEADER_BYTES]) -> Result<Header, ImageError> {
    if h.iter().all(|&b| b == 0xFF) {
        return Err(ImageError::Absent);
    }
    if h[0..4] != IMAGE_MAGIC || le_u16(h, 4) != IMAGE_VERSION {
        return Err(ImageError::Header);
    }
    let nd = usize::from(le_u16(h, 12));
    let np = usize::from(le_u16(h, 14));
    let fits = (2..=MAX_POINTS).contains(&nd)
        && (2..=MAX_POINTS).contains(&np)
        && nd + np + nd * np <= MAX_IMAGE_VALUES;
    if !fits {
        return Err(ImageError::Size);
    }
    Ok(Header {
        format_version: le_u16(h, 6),
        placeholder: h[8] & 1 != 0,
        nd,
        np,
        initial_diameter_mm: f32::from_bits(le_u32(h, 16)),
        expansion_length_mm: f32::from_bits(le_u32(h, 20)),
        skin_thickness_mm: f32::from_bits(le_u32(h, 24)),
        checksum: le_u32(h, 28),
    })
}

/// A table read from an image into RAM: the storage behind an uploaded
/// table ([`TableBuf::table`] borrows it).
#[derive(Clone, Debug, PartialEq)]
pub struct TableBuf {
    header: Header,
    values: [f32; MAX_IMAGE_VALUES],
}

impl TableBuf {
    /// Reads and checks the image at `offset` of `flash`: header, sizes,
    /// then [`Table::verify`] (format version, shape, axes, monotonic
    /// rows and the table's CRC-32).
    pub fn load<F: ReadNorFlash>(flash: &mut F, offset: u32) -> Result<TableBuf, ImageError> {
        let mut h = [0u8; HEADER_BYTES];
        flash.read(offset, &mut h).map_err(|_| ImageError::Read)?;
        let header = parse_header(&h)?;
        let mut buf = TableBuf {
            header,
            values: [0.0; MAX_IMAGE_VALUES],
        };
        let n = header.nd + header.np + header.nd * header.np;
        let mut at = offset + HEADER_BYTES as u32;
        let mut chunk = [0u8; 64];
        for block in buf.values[..n].chunks_mut(chunk.len() / 4) {
            let bytes = &mut chunk[..block.len() * 4];
            flash.read(at, bytes).map_err(|_| ImageError::Read)?;
            for (v, b) in block.iter_mut().zip(bytes.chunks_exact(4)) {
                *v = f32::from_bits(le_u32(b, 0));
            }
            at += bytes.len() as u32;
        }
        buf.table().verify().map_err(ImageError::Table)?;
        Ok(buf)
    }

    /// Reads and checks an image held in memory (`bytes` must be exactly
    /// one image long).
    pub fn parse(bytes: &[u8]) -> Result<TableBuf, ImageError> {
        let mut h = [0u8; HEADER_BYTES];
        h.copy_from_slice(bytes.get(..HEADER_BYTES).ok_or(ImageError::Size)?);
        let header = parse_header(&h)?;
        if bytes.len() != image_len(header.nd, header.np) {
            return Err(ImageError::Size);
        }
        let mut slice = SliceFlash(bytes);
        TableBuf::load(&mut slice, 0)
    }

    /// The table (borrowing this buffer).
    pub fn table(&self) -> Table<'_> {
        let (nd, np) = (self.header.nd, self.header.np);
        let (depths, rest) = self.values.split_at(nd);
        let (diameters, rest) = rest.split_at(np);
        Table {
            format_version: self.header.format_version,
            placeholder: self.header.placeholder,
            initial_diameter_mm: self.header.initial_diameter_mm,
            expansion_length_mm: self.header.expansion_length_mm,
            skin_thickness_mm: self.header.skin_thickness_mm,
            depths_mm: depths,
            diameters_mm: diameters,
            pressure_kpa: &rest[..nd * np],
            checksum: self.header.checksum,
        }
    }
}

/// A byte slice read as flash (for [`TableBuf::parse`]).
struct SliceFlash<'a>(&'a [u8]);

/// Reading past the slice.
#[derive(Debug)]
struct OutOfBounds;

impl embedded_storage::nor_flash::NorFlashError for OutOfBounds {
    fn kind(&self) -> embedded_storage::nor_flash::NorFlashErrorKind {
        embedded_storage::nor_flash::NorFlashErrorKind::OutOfBounds
    }
}

impl embedded_storage::nor_flash::ErrorType for SliceFlash<'_> {
    type Error = OutOfBounds;
}

impl ReadNorFlash for SliceFlash<'_> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), OutOfBounds> {
        let at = offset as usize;
        let src = self.0.get(at..at + bytes.len()).ok_or(OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.0.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::generated::TABLE;

    fn image() -> std::vec::Vec<u8> {
        let mut v = std::vec::Vec::new();
        write_image(&TABLE, &mut |b| v.extend_from_slice(b));
        v
    }

    #[test]
    fn round_trip_of_the_compiled_in_table() {
        let bytes = image();
        assert_eq!(
            bytes.len(),
            image_len(TABLE.depths_mm.len(), TABLE.diameters_mm.len())
        );
        let buf = TableBuf::parse(&bytes).unwrap();
        assert_eq!(buf.table(), TABLE);
    }

    #[test]
    fn damage_is_named() {
        let good = image();
        let mut bad = good.clone();
        bad[HEADER_BYTES + 40] ^= 0x01;
        assert_eq!(
            TableBuf::parse(&bad),
            Err(ImageError::Table(TableError::Checksum))
        );
        let mut bad = good.clone();
        bad[0] = b'X';
        assert_eq!(TableBuf::parse(&bad), Err(ImageError::Header));
        assert_eq!(
            TableBuf::parse(&good[..good.len() - 1]),
            Err(ImageError::Size)
        );
        assert_eq!(
            TableBuf::parse(&[0xFF; 64][..]).map(|_| ()),
            Err(ImageError::Absent)
        );
        let mut big = good.clone();
        big[12..14].copy_from_slice(&60u16.to_le_bytes());
        big[14..16].copy_from_slice(&60u16.to_le_bytes());
        assert_eq!(TableBuf::parse(&big), Err(ImageError::Size));
    }
}
