//! OpenEXR's ZIP codec (ZIP1 and ZIP16 blocks) for the writer, deflated by zlib-rs (through
//! flate2) instead of the exr crate's miniz_oxide. The file's structure stays the exr crate's:
//! its headers, block order and offset table (its block writer), and the bytes of each block
//! before compression (its block extraction). Only each block's compression is done here, at the
//! exr crate's zlib level: miniz_oxide's deflate was 15% of a 12-frame shot's CPU samples.
//!
//! The codec (OpenEXR's file layout document, "ZIP compression"): a block's little-endian bytes
//! are split into the bytes at even and at odd positions (the even ones first), each byte then
//! replaced by its difference to the one before plus 128 (mod 256), and the result deflated as a
//! zlib stream. A block that does not shrink is stored as it is.

use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
use exr::block::writer::ChunksWriter;
use exr::block::UncompressedBlock;
use exr::error::UnitResult;
use exr::image::write::layers::{LayersWriter, WritableLayers};
use exr::meta::header::Header;

/// The zlib level of the exr crate's ZIP blocks (`exr::compression::zip`), kept so that files
/// keep their size.
const ZIP_LEVEL: u32 = 4;

/// Whether `compression` is one this module writes.
pub(super) fn writes(compression: exr::compression::Compression) -> bool {
    use exr::compression::Compression;
    // The block's bytes are the machine's: little-endian is the file's order.
    cfg!(target_endian = "little") && matches!(compression, Compression::ZIP1 | Compression::ZIP16)
}

/// Write `image` (scan-line blocks of a compression [`writes`] takes) to `out`, its blocks
/// compressed on one thread per core (the exr crate's writer compresses in parallel too) and
/// written in the file's order.
pub(super) fn write_image<'a, L: WritableLayers<'a>>(
    out: impl std::io::Write + std::io::Seek,
    image: &'a exr::image::Image<L>,
) -> UnitResult {
    let headers = image.layer_data.infer_headers(&image.attributes);
    let layers = image.layer_data.create_writer(&headers);
    exr::block::write(out, headers, true, move |meta, chunks| {
        let blocks: Vec<(usize, UncompressedBlock)> =
            meta.collect_ordered_block_data(|index| layers.extract_uncompressed_block(&meta.headers, index)).collect();
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(blocks.len().max(1));
        let per_thread = blocks.len().div_ceil(threads).max(1);
        let headers = &meta.headers;
        let compressed: Vec<exr::error::Result<Vec<(usize, Chunk)>>> = std::thread::scope(|scope| {
            let parts: Vec<_> = blocks
                .chunks(per_thread)
                .map(|part| {
                    scope.spawn(move || part.iter().map(|(i, block)| Ok((*i, zip_chunk(headers, block)?))).collect())
                })
                .collect();
            parts
                .into_iter()
                .map(|part| {
                    part.join()
                        .unwrap_or_else(|_| Err(exr::error::Error::Invalid("a compressing thread stopped".into())))
                })
                .collect()
        });
        for part in compressed {
            for (index_in_header, chunk) in part? {
                chunks.write_chunk(index_in_header, chunk)?;
            }
        }
        Ok(())
    })
}

/// A scan-line block as a ZIP chunk.
fn zip_chunk(headers: &[Header], block: &UncompressedBlock) -> exr::error::Result<Chunk> {
    let header = &headers[block.index.layer];
    let zipped = zip_bytes(&block.data)?;
    let y = block.index.pixel_position.y() as i32 + header.own_attributes.layer_position.y();
    let compressed_pixels_le = if zipped.len() < block.data.len() { zipped } else { block.data.clone() };
    Ok(Chunk {
        layer_index: block.index.layer,
        compressed_block: CompressedBlock::ScanLine(CompressedScanLineBlock { y_coordinate: y, compressed_pixels_le }),
    })
}

/// The ZIP codec's bytes of `raw` (a block's little-endian bytes).
pub(super) fn zip_bytes(raw: &[u8]) -> std::io::Result<Vec<u8>> {
    let half = raw.len().div_ceil(2);
    let mut split = vec![0u8; raw.len()];
    let (evens, odds) = split.split_at_mut(half);
    for ((even, odd), pair) in evens.iter_mut().zip(odds.iter_mut()).zip(raw.chunks_exact(2)) {
        *even = pair[0];
        *odd = pair[1];
    }
    if raw.len() % 2 == 1 {
        evens[half - 1] = raw[raw.len() - 1];
    }
    // From the end, so that each byte's predecessor is still the original.
    for i in (1..split.len()).rev() {
        split[i] = split[i].wrapping_sub(split[i - 1]).wrapping_add(128);
    }
    let mut compressor = flate2::Compress::new(flate2::Compression::new(ZIP_LEVEL), true);
    // zlib's bound for one stream: the data, 5 bytes per 16 kB stored block, the header and check.
    let mut out = Vec::with_capacity(split.len() + split.len() / 16_000 * 5 + 64);
    loop {
        let status = compressor
            .compress_vec(&split[compressor.total_in() as usize..], &mut out, flate2::FlushCompress::Finish)
            .map_err(std::io::Error::other)?;
        if status == flate2::Status::StreamEnd {
            return Ok(out);
        }
        out.reserve(out.capacity().max(64));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The codec undone: inflate, add back the differences, interleave the halves.
    fn unzip(zipped: &[u8], len: usize) -> Vec<u8> {
        let mut inflated = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::ZlibDecoder::new(zipped), &mut inflated).unwrap();
        assert_eq!(inflated.len(), len);
        for i in 1..inflated.len() {
            inflated[i] = inflated[i].wrapping_add(inflated[i - 1]).wrapping_sub(128);
        }
        let half = len.div_ceil(2);
        (0..len).map(|i| inflated[if i % 2 == 0 { i / 2 } else { half + i / 2 }]).collect()
    }

    #[test]
    fn a_block_comes_back_from_the_codec_byte_for_byte() {
        // Even and odd lengths, an empty block, and half floats of a smooth ramp (the case the
        // byte split and the differences are made for: it must shrink).
        let ramp: Vec<u8> = (0..4096u32).flat_map(|i| half::f16::from_f32(i as f32 / 4096.0).to_le_bytes()).collect();
        for raw in [ramp.clone(), vec![7u8, 200, 3], vec![], (0..1001u32).map(|i| (i * 37 % 251) as u8).collect()] {
            let zipped = zip_bytes(&raw).unwrap();
            assert_eq!(unzip(&zipped, raw.len()), raw, "{} bytes", raw.len());
        }
        assert!(zip_bytes(&ramp).unwrap().len() * 4 < ramp.len(), "a smooth ramp of halves compresses at least 4:1");
    }
}
