//! Typed reads of glTF accessors, with every bound checked.

use gltf::accessor::{DataType, Dimensions};

use super::Reason;

/// Reads an accessor's components (`count × components` values, exact as f64 for every component
/// type), after checking its type and that it lies inside its buffer view and buffer.
fn read_accessor(
    accessor: &gltf::Accessor,
    buffers: &[Vec<u8>],
    what: &str,
    dimensions: Dimensions,
    types: &[DataType],
) -> Reason<(DataType, Vec<f64>)> {
    let index = accessor.index();
    if accessor.sparse().is_some() {
        return Err(format!("{what} uses a sparse accessor (accessor {index}), which diffsil does not support"));
    }
    if accessor.dimensions() != dimensions {
        return Err(format!("{what}: accessor {index} has type {:?}, expected {dimensions:?}", accessor.dimensions()));
    }
    let data_type = accessor.data_type();
    if !types.contains(&data_type) {
        return Err(format!("{what}: accessor {index} has component type {data_type:?}, expected one of {types:?}"));
    }
    let count = accessor.count();
    if count == 0 {
        return Ok((data_type, Vec::new()));
    }
    let view = accessor.view().ok_or_else(|| format!("{what}: accessor {index} has no buffer view"))?;
    let buffer = view.buffer().index();
    let view_bytes = view
        .offset()
        .checked_add(view.length())
        .and_then(|end| buffers.get(buffer)?.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "{what}: buffer view {} ({} bytes at offset {}) lies outside buffer {buffer}",
                view.index(),
                view.length(),
                view.offset()
            )
        })?;
    let components = dimensions.multiplicity();
    let size = data_type.size();
    let element = components * size;
    let stride = view.stride().unwrap_or(element);
    if stride < element {
        return Err(format!(
            "{what}: buffer view {} has a byte stride of {stride}, less than the {element}-byte elements",
            view.index()
        ));
    }
    let end = stride
        .checked_mul(count - 1)
        .and_then(|x| x.checked_add(element))
        .and_then(|x| x.checked_add(accessor.offset()));
    if end.is_none_or(|end| end > view_bytes.len()) {
        return Err(format!(
            "{what}: accessor {index} ({count} elements of {element} bytes, stride {stride}, offset {}) overruns \
             its buffer view {} of {} bytes",
            accessor.offset(),
            view.index(),
            view_bytes.len()
        ));
    }
    let mut values = Vec::with_capacity(count * components);
    for e in 0..count {
        let start = accessor.offset() + e * stride;
        for c in 0..components {
            let b = &view_bytes[start + c * size..start + (c + 1) * size];
            values.push(match data_type {
                DataType::I8 => f64::from(b[0] as i8),
                DataType::U8 => f64::from(b[0]),
                DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
                DataType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
                DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            });
        }
    }
    Ok((data_type, values))
}

/// Float vectors (`N` components): `F32`, or also normalized unsigned byte / short when
/// `normalized_ok` (mapped to [0, 1]).
pub(super) fn read_floats<const N: usize>(
    accessor: &gltf::Accessor,
    buffers: &[Vec<u8>],
    what: &str,
    dimensions: Dimensions,
    normalized_ok: bool,
) -> Reason<Vec<[f32; N]>> {
    let types: &[DataType] =
        if normalized_ok { &[DataType::F32, DataType::U8, DataType::U16] } else { &[DataType::F32] };
    let (data_type, values) = read_accessor(accessor, buffers, what, dimensions, types)?;
    let scale = match data_type {
        DataType::U8 => 1.0 / 255.0,
        DataType::U16 => 1.0 / 65535.0,
        _ => 1.0,
    };
    if data_type != DataType::F32 && !accessor.normalized() {
        return Err(format!("{what}: integer accessor {} must be normalized", accessor.index()));
    }
    Ok(values.chunks_exact(N).map(|c| std::array::from_fn(|k| (c[k] * scale) as f32)).collect())
}

/// Triangle indices: unsigned byte, short or int scalars.
pub(super) fn read_indices(accessor: &gltf::Accessor, buffers: &[Vec<u8>], what: &str) -> Reason<Vec<u32>> {
    let types = [DataType::U8, DataType::U16, DataType::U32];
    let (_, values) = read_accessor(accessor, buffers, what, Dimensions::Scalar, &types)?;
    Ok(values.into_iter().map(|v| v as u32).collect())
}

/// Joint indices: four unsigned bytes or shorts per vertex.
pub(super) fn read_joints(accessor: &gltf::Accessor, buffers: &[Vec<u8>], what: &str) -> Reason<Vec<[u16; 4]>> {
    let (_, values) = read_accessor(accessor, buffers, what, Dimensions::Vec4, &[DataType::U8, DataType::U16])?;
    Ok(values.chunks_exact(4).map(|c| std::array::from_fn(|k| c[k] as u16)).collect())
}
