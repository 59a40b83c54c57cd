//! Validation of a whole `.pvis` file, once, at `Pvis::parse` (spec § Header … § Trailer).
//!
//! Checks everything a later query relies on, so that queries need no checks and cannot fail:
//! header, CRC, section table placement, every CAMR field, every patch record, VISB length and
//! padding bits, and in version 5 the SHEL section: its records and each shell's payload, which
//! is a VISB body checked by the same code. Order: signature, version, flags, length, checksum, then structure — a
//! corrupted file is reported as corrupted before any of its fields is believed.
//! Cost: one CRC pass over the file plus one pass over PTCH and the last byte of every VISB row;
//! no allocation.

use super::consts::*;
use super::crc32c::crc32c;
use super::fields::{POSITIVE, Section, at, finite3, float, read, reserved};
use super::model::{FEATURES, LEAF, MAX_TREE_DEPTH, MAX_TREE_NODES};
use super::ptch::{self, PatchTable};
use super::shells::Shells;
use super::stream::Stream;
use super::visb::{Model, Visb, read_varint};
use super::{Error, Pvis, Rule, Sampling};

pub(super) fn parse(data: &[u8]) -> Result<Pvis<'_>, Error> {
    let have = data.len();
    let len = have as u64;

    // § Header. The signature is compared on whatever prefix exists, so a short file of the
    // wrong kind reads as "not a .pvis file" rather than "truncated". Byte by byte rather than
    // as slices, so that the embedded reader links no `memcmp`.
    if MAGIC.iter().zip(data).any(|(m, d)| m != d) {
        return Err(Error::BadMagic);
    }
    if len < HEADER_LEN + TRAILER_LEN {
        return Err(Error::Truncated {
            needed: HEADER_LEN + TRAILER_LEN,
            have: len,
        });
    }
    let mut s = Stream::new_at(data, MAGIC.len());
    let version = read::<u32>(&mut s, have)?;
    if !(MIN_VERSION..=VERSION).contains(&version) {
        return Err(Error::UnsupportedVersion { found: version });
    }
    let flags = read::<u32>(&mut s, have)?;
    if flags & !KNOWN_FLAGS != 0 {
        return Err(Error::UnknownFlags { flags });
    }
    let file_length = read::<u64>(&mut s, have)?;
    if file_length != len {
        return Err(Error::LengthMismatch {
            header: file_length,
            actual: len,
        });
    }

    // § Trailer.
    let body_end = len - TRAILER_LEN;
    let stored = read::<u32>(&mut Stream::new_at(data, at(body_end)), have)?;
    let computed = crc32c(&data[..at(body_end)]);
    if stored != computed {
        return Err(Error::ChecksumMismatch { stored, computed });
    }

    let count_offset = s.offset() as u64;
    let section_count = read::<u32>(&mut s, have)?;
    if section_count == 0 {
        return Err(Error::Invalid {
            what: Rule::HeaderSectionCount,
            offset: count_offset,
            value: 0,
        });
    }
    if section_count > MAX_SECTIONS {
        return Err(Error::LimitExceeded {
            what: Rule::SectionCount,
            value: section_count as u64,
            limit: MAX_SECTIONS as u64,
        });
    }
    reserved(&mut s, have, Rule::HeaderReserved)?;

    // § Section table.
    let table_end = HEADER_LEN + SECTION_ENTRY_LEN * section_count as u64;
    if table_end > body_end {
        return Err(Error::Truncated {
            needed: table_end + TRAILER_LEN,
            have: len,
        });
    }
    let (mut camr, mut ptch, mut visb, mut shel) = (None, None, None, None);
    let mut previous_end = table_end;
    for _ in 0..section_count {
        let tag = read::<[u8; 4]>(&mut s, have)?;
        reserved(&mut s, have, Rule::TableReserved)?;
        let offset = read::<u64>(&mut s, have)?;
        let length = read::<u64>(&mut s, have)?;
        if offset % SECTION_ALIGN != 0 {
            return Err(Error::SectionMisaligned { tag, offset });
        }
        let end = offset.checked_add(length);
        if offset < previous_end || end.is_none_or(|end| end > body_end) {
            return Err(Error::SectionOutOfBounds {
                tag,
                offset,
                length,
                start: previous_end,
                end: body_end,
            });
        }
        // The gap before this section is unused; it must be zero so the whole file has one
        // meaning (and so a checksum-valid file cannot smuggle data past the reader).
        zero_gap(data, previous_end, offset)?;
        previous_end = offset + length;
        let slot = match tag {
            TAG_CAMR => &mut camr,
            TAG_PTCH => &mut ptch,
            TAG_VISB => &mut visb,
            // Before version 5 a SHEL-tagged section is an unknown one (§ SHEL).
            TAG_SHEL if version >= SHELLS_VERSION => &mut shel,
            // Unknown sections are skipped: forward compatibility (§ Versioning).
            _ => continue,
        };
        if slot.is_some() {
            return Err(Error::DuplicateSection { tag });
        }
        *slot = Some(Section { offset, length });
    }
    zero_gap(data, previous_end, body_end)?;
    let camr = camr.ok_or(Error::MissingSection { tag: TAG_CAMR })?;
    let ptch = ptch.ok_or(Error::MissingSection { tag: TAG_PTCH })?;
    let visb = visb.ok_or(Error::MissingSection { tag: TAG_VISB })?;

    let sampling = parse_camr(data, camr)?;
    let (patches, patch_count, triangle_count) = ptch::parse(data, ptch, version)?;
    let payload = parse_visb(
        data,
        visb,
        TAG_VISB,
        version,
        sampling,
        patch_count,
        patches,
    )?;
    let shells = match shel {
        // A far-only reader (spec § SHEL, far-only readers) skips SHEL's contents.
        Some(section) if cfg!(feature = "shells") => {
            parse_shel(data, section, version, sampling, patch_count, patches)?
        }
        _ => Shells::NONE,
    };

    Ok(Pvis {
        bytes: data,
        sampling,
        patch_count,
        triangle_count,
        patches,
        visb: payload,
        shells,
        visibility_bytes: visb.length,
        patch_table_bytes: ptch.length,
    })
}

/// Checks that `data[start..end]` (unused space between sections) is zero.
fn zero_gap(data: &[u8], start: u64, end: u64) -> Result<(), Error> {
    let gap = data.get(at(start)..at(end)).unwrap_or(&[]);
    match gap.iter().position(|&b| b != 0) {
        None => Ok(()),
        Some(i) => Err(Error::Invalid {
            what: Rule::Gap,
            offset: start + i as u64,
            value: gap[i] as u64,
        }),
    }
}

/// § CAMR.
fn parse_camr(data: &[u8], section: Section) -> Result<Sampling, Error> {
    if section.length != CAMR_LEN {
        return Err(Error::SectionLength {
            tag: TAG_CAMR,
            length: section.length,
            expected: CAMR_LEN,
        });
    }
    let have = data.len();
    let mut s = Stream::new_at(data, at(section.offset));
    let level = read::<u32>(&mut s, have)?;
    if level > MAX_LEVEL {
        return Err(Error::LimitExceeded {
            what: Rule::SphereLevel,
            value: level as u64,
            limit: MAX_LEVEL as u64,
        });
    }
    let views = read::<u32>(&mut s, have)?;
    let expected = crate::sphere::view_count(level);
    if views != expected {
        return Err(Error::ViewCountMismatch {
            level,
            found: views,
            expected,
        });
    }
    let center = finite3(&mut s, have, Rule::CamrCenter)?;
    let radius = float(&mut s, have, Rule::CamrRadius, POSITIVE)?;
    let distance = float(&mut s, have, Rule::CamrDistance, [radius, f32::MAX])?;
    let fov_deg = float(
        &mut s,
        have,
        Rule::CamrFov,
        [0f32.next_up(), 180f32.next_down()],
    )?;
    let resolution_offset = s.offset() as u64;
    let resolution = read::<u32>(&mut s, have)?;
    if resolution == 0 {
        return Err(Error::Invalid {
            what: Rule::CamrResolution,
            offset: resolution_offset,
            value: 0,
        });
    }
    let convention_offset = s.offset() as u64;
    let convention = read::<u32>(&mut s, have)?;
    if convention != SPHERE_CONVENTION {
        return Err(Error::Invalid {
            what: Rule::CamrConvention,
            offset: convention_offset,
            value: convention as u64,
        });
    }
    reserved(&mut s, have, Rule::CamrReserved)?;
    Ok(Sampling {
        level,
        views,
        center,
        radius,
        distance,
        fov_deg,
        resolution,
    })
}

/// § SHEL: the shell count, every shell record (distances strictly decreasing down to no less
/// than the radius, none at CAMR's distance, and below it before version 6; levels; lengths
/// that tile the rest of the section) and each payload as a VISB body of its level's views.
fn parse_shel<'a>(
    data: &'a [u8],
    section: Section,
    version: u32,
    sampling: Sampling,
    patch_count: u32,
    patches: PatchTable<'a>,
) -> Result<Shells<'a>, Error> {
    if section.length < SHEL_HEADER_LEN {
        return Err(Error::BadSection { tag: TAG_SHEL });
    }
    let have = data.len();
    let mut s = Stream::new_at(data, at(section.offset));
    let count = read::<u32>(&mut s, have)?;
    if count == 0 || count > MAX_SHELLS {
        return Err(Error::Invalid {
            what: Rule::ShellCount,
            offset: section.offset,
            value: count as u64,
        });
    }
    // Checked once `J` is known, after the records.
    let reach = read::<u32>(&mut s, have)?;
    // Cannot overflow: count ≤ 8.
    let records_end = SHEL_HEADER_LEN + SHELL_RECORD_LEN * count as u64;
    if section.length < records_end {
        return Err(Error::SectionLength {
            tag: TAG_SHEL,
            length: section.length,
            expected: records_end,
        });
    }
    // The section lies inside the file and holds every record: the records are read as
    // queries read them, and only their rules can fail.
    let body = data
        .get(at(section.offset)..at(section.offset + section.length))
        .unwrap_or(&[]);
    let mut shells = Shells::new(body, section.offset, count);
    // Version 6 lets the first records lie beyond the sampling distance (the far band).
    let mut outer = if version >= FAR_BAND_VERSION {
        f32::INFINITY
    } else {
        sampling.distance
    };
    let mut payloads = 0u64;
    for k in 1..count + 1 {
        let record = section.offset + SHEL_HEADER_LEN + SHELL_RECORD_LEN * u64::from(k - 1);
        let distance = shells.distance(k);
        // Strictly decreasing, finite, never the sampling sphere's own distance, and inside
        // it no nearer than the radius. Below `outer` and at least the radius, it is neither
        // NaN nor infinite.
        if !(distance >= sampling.radius && distance < outer && distance != sampling.distance) {
            return Err(Error::InvalidFloat {
                what: Rule::ShellDistance,
                offset: record,
                bits: distance.to_bits(),
            });
        }
        if distance > sampling.distance {
            shells.sampling_at = k;
        }
        outer = distance;
        let level = shells.level(k);
        if level > MAX_LEVEL {
            return Err(Error::LimitExceeded {
                what: Rule::ShellLevel,
                value: level as u64,
                limit: MAX_LEVEL as u64,
            });
        }
        payloads = payloads.saturating_add(shells.payload_length(k));
    }
    // `reach`: 0, or (with a far band) a finite binary32 above the sampling distance.
    shells.reach = f32::from_bits(reach);
    if reach != 0
        && !(shells.sampling_at > 0 && shells.reach > sampling.distance && shells.reach <= f32::MAX)
    {
        return Err(Error::InvalidFloat {
            what: Rule::ShelReach,
            offset: section.offset + 4,
            bits: reach,
        });
    }
    if section.length - records_end != payloads {
        return Err(Error::SectionLength {
            tag: TAG_SHEL,
            length: section.length,
            expected: records_end.saturating_add(payloads),
        });
    }
    for k in 1..count + 1 {
        let level = shells.level(k);
        let shell = shell_sampling(sampling, level);
        let visb = parse_visb(
            data,
            shells.payload(k),
            TAG_SHEL,
            version,
            shell,
            patch_count,
            patches,
        )
        .map_err(Error::in_shell_payload)?;
        shells.max_level = shells.max_level.max(level);
        shells.tree |= matches!(
            visb,
            Visb::Hierarchical {
                model: Model::Tree { .. },
                ..
            }
        );
    }
    Ok(shells)
}

/// The sampling parameters a shell's payload is checked against: the file's, with the shell's
/// level and its views.
fn shell_sampling(sampling: Sampling, level: u32) -> Sampling {
    Sampling {
        level,
        views: crate::sphere::view_count(level.min(MAX_LEVEL)),
        ..sampling
    }
}

/// § VISB: the fixed part, then encoding 0, 1 or 2 — of the VISB section, or (`tag` SHEL) of a
/// shell's payload, which follows the same rules.
pub(super) fn parse_visb<'a>(
    data: &'a [u8],
    section: Section,
    tag: [u8; 4],
    version: u32,
    sampling: Sampling,
    patch_count: u32,
    patches: PatchTable<'a>,
) -> Result<Visb<'a>, Error> {
    if section.length < VISB_HEADER_LEN {
        return Err(Error::BadSection { tag });
    }
    let have = data.len();
    let mut s = Stream::new_at(data, at(section.offset));
    let encoding = read::<u32>(&mut s, have)?;
    reserved(&mut s, have, Rule::VisbReserved)?;
    match encoding {
        ENCODING_RAW => parse_raw(data, section, tag, sampling.views, patch_count)?,
        ENCODING_HIERARCHICAL if version >= 2 => {
            let model_end = parse_table(data, section, tag, sampling)?;
            parse_records(data, section, tag, model_end, sampling, patch_count)?;
        }
        ENCODING_TREE if version >= 3 => {
            let model_end = parse_tree(data, section, tag)?;
            parse_records(data, section, tag, model_end, sampling, patch_count)?;
        }
        found => return Err(Error::UnsupportedEncoding { tag, found }),
    }
    // Where the model, checkpoints and records lie, read as a shell's rows are read when they
    // are opened again for a query.
    let body = &data[at(section.offset)..at(section.offset + section.length)];
    Ok(Visb::at(body, sampling.level, patch_count, patches))
}

/// § VISB, encoding 0: length and padding bits.
fn parse_raw(
    data: &[u8],
    section: Section,
    tag: [u8; 4],
    views: u32,
    patch_count: u32,
) -> Result<(), Error> {
    let have = data.len();
    let row_len = row_bytes(patch_count);
    // Cannot overflow: views ≤ 2^18, row_len ≤ 2^17.
    let expected = VISB_HEADER_LEN + views as u64 * row_len;
    if section.length != expected {
        return Err(Error::SectionLength {
            tag,
            length: section.length,
            expected,
        });
    }
    let rows_offset = section.offset + VISB_HEADER_LEN;
    let used_bits = patch_count % 8;
    if used_bits != 0 {
        let padding_mask = !0u8 << used_bits;
        for view in 0..views {
            let last = rows_offset + (view as u64 + 1) * row_len - 1;
            let byte = data.get(at(last)).copied().ok_or(Error::Truncated {
                needed: last + 1,
                have: have as u64,
            })?;
            if byte & padding_mask != 0 {
                return Err(Error::PaddingBits {
                    tag,
                    view,
                    offset: last,
                });
            }
        }
    }
    Ok(())
}

/// § VISB, encoding 1: the probability table. Returns where it ends.
fn parse_table(
    data: &[u8],
    section: Section,
    tag: [u8; 4],
    sampling: Sampling,
) -> Result<u64, Error> {
    let end = section.offset + section.length;
    let probs_start = section.offset + VISB_HEADER_LEN;
    // Cannot overflow: level ≤ 7.
    let probs_end = probs_start + (sampling.level as u64 + 1) * CONTEXTS as u64 * 2;
    if probs_end > end {
        return Err(Error::SectionLength {
            tag,
            length: section.length,
            expected: probs_end - section.offset,
        });
    }
    let probs = &data[at(probs_start)..at(probs_end)];
    for (i, pair) in probs.chunks_exact(2).enumerate() {
        let p0 = u16::from_le_bytes([pair[0], pair[1]]);
        if p0 == 0 || u32::from(p0) >= 1 << PROB_BITS {
            return Err(Error::Invalid {
                what: Rule::VisbProbability,
                offset: probs_start + 2 * i as u64,
                value: p0 as u64,
            });
        }
    }
    Ok(probs_end)
}

/// § VISB, encoding 2: the context tree — node count, every node's fields, children after
/// their parent, depth. Returns where it ends.
fn parse_tree(data: &[u8], section: Section, tag: [u8; 4]) -> Result<u64, Error> {
    let end = section.offset + section.length;
    let count_at = section.offset + VISB_HEADER_LEN;
    if count_at + 4 > end {
        return Err(Error::SectionLength {
            tag,
            length: section.length,
            expected: count_at + 4 - section.offset,
        });
    }
    let count = read::<u32>(&mut Stream::new_at(data, at(count_at)), data.len())?;
    if count == 0 || count > MAX_TREE_NODES {
        return Err(Error::Invalid {
            what: Rule::TreeNodeCount,
            offset: count_at,
            value: count as u64,
        });
    }
    let nodes_start = count_at + 4;
    let nodes_end = nodes_start + 2 * count as u64;
    if nodes_end > end {
        return Err(Error::SectionLength {
            tag,
            length: section.length,
            expected: nodes_end - section.offset,
        });
    }
    let nodes = &data[at(nodes_start)..at(nodes_end)];
    // Depth (internal nodes above) of every node reached so far; children follow parents, so
    // one forward pass sees every parent before its children.
    let mut depth = [0u8; MAX_TREE_NODES as usize];
    for (i, pair) in nodes.chunks_exact(2).enumerate() {
        let node = u16::from_le_bytes([pair[0], pair[1]]);
        let offset = nodes_start + 2 * i as u64;
        if node & LEAF != 0 {
            let p0 = node & !LEAF;
            if p0 == 0 || u32::from(p0) >= 1 << PROB_BITS {
                return Err(Error::Invalid {
                    what: Rule::TreeLeaf,
                    offset,
                    value: node as u64,
                });
            }
            continue;
        }
        let feature = u32::from(node >> 10);
        if feature >= FEATURES {
            return Err(Error::Invalid {
                what: Rule::TreeFeature,
                offset,
                value: node as u64,
            });
        }
        let child = usize::from(node & 0x3FF);
        if child <= i || child + 1 >= count as usize {
            return Err(Error::Invalid {
                what: Rule::TreeChildren,
                offset,
                value: node as u64,
            });
        }
        let d = depth[i] + 1;
        if u32::from(d) > MAX_TREE_DEPTH {
            return Err(Error::LimitExceeded {
                what: Rule::TreeDepth,
                value: d as u64,
                limit: MAX_TREE_DEPTH as u64,
            });
        }
        depth[child] = depth[child].max(d);
        depth[child + 1] = depth[child + 1].max(d);
    }
    Ok(nodes_end)
}

/// § VISB, encodings 1 and 2: checkpoints, and every view record's length prefix and code
/// bounds, after the model that ends at `model_end`. The codes themselves need no check:
/// every byte string decodes (§ Range coder), so after this no decode can fail.
fn parse_records(
    data: &[u8],
    section: Section,
    tag: [u8; 4],
    model_end: u64,
    sampling: Sampling,
    patch_count: u32,
) -> Result<(), Error> {
    let have = data.len() as u64;
    let end = section.offset + section.length;
    let probs_end = model_end;
    // Cannot overflow: views ≤ 2^17.
    let checkpoints_end = probs_end + 4 * sampling.views.div_ceil(CHECKPOINT_INTERVAL) as u64;
    if checkpoints_end > end {
        return Err(Error::SectionLength {
            tag,
            length: section.length,
            expected: checkpoints_end - section.offset,
        });
    }
    let records = &data[at(checkpoints_end)..at(end)];
    let max_len = max_code_len(patch_count);
    let mut pos = 0usize;
    for view in 0..sampling.views {
        let offset = checkpoints_end + pos as u64;
        if view % CHECKPOINT_INTERVAL == 0 {
            let k = at(probs_end) + 4 * (view / CHECKPOINT_INTERVAL) as usize;
            let stored = read::<u32>(&mut Stream::new_at(data, k), data.len())?;
            if stored as usize != pos {
                return Err(Error::Invalid {
                    what: Rule::Checkpoint,
                    offset: k as u64,
                    value: stored as u64,
                });
            }
        }
        let (len, n) = read_varint(records, pos).ok_or(Error::Invalid {
            what: Rule::RecordLength,
            offset,
            value: view as u64,
        })?;
        if n > 1 && records[pos + n - 1] == 0 {
            return Err(Error::Invalid {
                what: Rule::RecordLengthMinimal,
                offset,
                value: len as u64,
            });
        }
        if len as u64 > max_len {
            return Err(Error::LimitExceeded {
                what: Rule::CodeLength,
                value: len as u64,
                limit: max_len,
            });
        }
        let code_end = pos + n + len as usize;
        if code_end > records.len() {
            return Err(Error::Truncated {
                needed: checkpoints_end + code_end as u64,
                have: end.min(have),
            });
        }
        if len > 0 && records[code_end - 1] == 0 {
            return Err(Error::Invalid {
                what: Rule::CodeEnd,
                offset: checkpoints_end + code_end as u64 - 1,
                value: view as u64,
            });
        }
        pos = code_end;
    }
    if pos != records.len() {
        return Err(Error::SectionLength {
            tag,
            length: section.length,
            expected: section.length - (records.len() - pos) as u64,
        });
    }
    Ok(())
}
