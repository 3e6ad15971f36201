//! Reading accessors into `f32`s with every index, type, count and range checked first, so a
//! malformed file gives an error instead of reaching a panicking path. Handles strided views,
//! normalised integers, accessors without a view (zeros) and sparse substitution.

use std::borrow::Cow;
use std::path::Path;

use gltf::json::Root;
use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;

use super::container::load_buffer;
use crate::error::ImportError;

/// Largest element count accepted for an accessor (far above any real animation).
const MAX_COUNT: usize = 1 << 26;

/// Which component types an accessor may use.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Components {
    /// `FLOAT` only.
    Float,
    /// `FLOAT`, or normalised `BYTE`, `UNSIGNED_BYTE`, `SHORT`, `UNSIGNED_SHORT` (rotations).
    FloatOrNormalized,
    /// Plain (not normalised) `UNSIGNED_BYTE` or `UNSIGNED_SHORT`, read as their integer values
    /// (joint indices).
    Index,
}

/// Reads accessors of one document, loading the buffers it needs on first use.
pub(crate) struct Reader<'a> {
    root: &'a Root,
    bin: Option<&'a [u8]>,
    base: Option<&'a Path>,
    buffers: Vec<Option<Cow<'a, [u8]>>>,
}

fn dims(t: Type) -> usize {
    match t {
        Type::Scalar => 1,
        Type::Vec2 => 2,
        Type::Vec3 => 3,
        Type::Vec4 | Type::Mat2 => 4,
        Type::Mat3 => 9,
        Type::Mat4 => 16,
    }
}

fn comp_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

#[inline]
fn read_component(b: &[u8], c: ComponentType, raw: bool) -> f32 {
    if raw {
        return match c {
            ComponentType::U8 => b[0] as f32,
            _ => u16::from_le_bytes([b[0], b[1]]) as f32,
        };
    }
    match c {
        ComponentType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        ComponentType::I8 => ((b[0] as i8) as f32 / 127.0).max(-1.0),
        ComponentType::U8 => b[0] as f32 / 255.0,
        ComponentType::I16 => (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0),
        ComponentType::U16 => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
        ComponentType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
    }
}

fn to_usize(v: u64) -> Option<usize> {
    usize::try_from(v).ok()
}

impl<'a> Reader<'a> {
    pub(crate) fn new(root: &'a Root, bin: Option<&'a [u8]>, base: Option<&'a Path>) -> Self {
        Reader {
            root,
            bin,
            base,
            buffers: (0..root.buffers.len()).map(|_| None).collect(),
        }
    }

    /// The bytes of buffer view `view` (checked against its buffer).
    fn view_bytes(
        &mut self,
        view: usize,
        acc: usize,
    ) -> Result<(&[u8], Option<usize>), ImportError> {
        let err = |reason: String| ImportError::Accessor { index: acc, reason };
        let v = self
            .root
            .buffer_views
            .get(view)
            .ok_or_else(|| err(format!("buffer view {view} does not exist")))?;
        let bi = v.buffer.value();
        let buffer = self
            .root
            .buffers
            .get(bi)
            .ok_or_else(|| err(format!("buffer {bi} does not exist")))?;
        if self.buffers[bi].is_none() {
            let data = load_buffer(
                bi,
                buffer.uri.as_deref(),
                buffer.byte_length.0,
                self.bin,
                self.base,
            )?;
            self.buffers[bi] = Some(data);
        }
        let data: &[u8] = self.buffers[bi].as_deref().unwrap_or(&[]);
        let offset = v.byte_offset.map_or(Some(0), |o| to_usize(o.0));
        let length = to_usize(v.byte_length.0);
        let range = offset
            .zip(length)
            .and_then(|(o, l)| Some(o..o.checked_add(l)?))
            .filter(|r| r.end <= data.len())
            .ok_or_else(|| err(format!("buffer view {view} lies outside buffer {bi}")))?;
        Ok((&data[range], v.byte_stride.map(|s| s.0)))
    }

    /// Reads accessor `index` as `count × dims` floats after checking that its type has `want`
    /// components per element and its component type is allowed.
    pub(crate) fn read(
        &mut self,
        index: usize,
        want: Type,
        allowed: Components,
    ) -> Result<Vec<f32>, ImportError> {
        let err = |reason: String| ImportError::Accessor { index, reason };
        let acc = self
            .root
            .accessors
            .get(index)
            .ok_or_else(|| err("does not exist".into()))?;
        let Checked::Valid(ty) = acc.type_ else {
            return Err(err("unknown type".into()));
        };
        if ty != want {
            return Err(err(format!("has type {ty:?}, expected {want:?}")));
        }
        let Checked::Valid(ct) = acc.component_type else {
            return Err(err("unknown component type".into()));
        };
        let ct = ct.0;
        let raw = allowed == Components::Index;
        let ok = match (ct, allowed) {
            (ComponentType::U8 | ComponentType::U16, Components::Index) => !acc.normalized,
            (_, Components::Index) => false,
            (ComponentType::F32, _) => true,
            (ComponentType::U32, _) => false,
            (_, Components::FloatOrNormalized) => acc.normalized,
            (_, Components::Float) => false,
        };
        if !ok {
            return Err(err(format!(
                "component type {ct:?} (normalized: {}) is not allowed here",
                acc.normalized
            )));
        }
        let d = dims(ty);
        let cs = comp_size(ct);
        let elem = d * cs;
        let count = to_usize(acc.count.0)
            .filter(|&c| c <= MAX_COUNT)
            .ok_or_else(|| err("count too large".into()))?;
        let mut out = vec![0.0f32; count * d];
        if let Some(view) = acc.buffer_view {
            let offset = acc
                .byte_offset
                .map_or(Some(0), |o| to_usize(o.0))
                .ok_or_else(|| err("bad offset".into()))?;
            let view_offset = self
                .root
                .buffer_views
                .get(view.value())
                .and_then(|v| v.byte_offset)
                .map_or(0, |o| o.0);
            let (bytes, stride) = self.view_bytes(view.value(), index)?;
            // glTF 2.0 (3.6.2.4, data alignment): the accessor's offset within its buffer view
            // and the view's offset within its buffer are multiples of the component size, and
            // so is the stride; a misaligned float read would straddle two values.
            if offset % cs != 0 || view_offset % cs as u64 != 0 {
                return Err(err(format!(
                    "byte offset {offset} (buffer view at {view_offset}) is not a multiple of the \
                     component size {cs}"
                )));
            }
            if stride.is_some_and(|s| s % cs != 0) {
                return Err(err(format!(
                    "byte stride {} is not a multiple of the component size {cs}",
                    stride.unwrap_or(0)
                )));
            }
            let stride = stride.unwrap_or(elem);
            if stride < elem {
                return Err(err(format!(
                    "stride {stride} is smaller than the element size {elem}"
                )));
            }
            if count > 0 {
                let last = (count - 1)
                    .checked_mul(stride)
                    .and_then(|x| x.checked_add(offset))
                    .and_then(|x| x.checked_add(elem));
                if last.is_none_or(|end| end > bytes.len()) {
                    return Err(err(format!(
                        "{count} elements do not fit in buffer view {}",
                        view.value()
                    )));
                }
            }
            for i in 0..count {
                let at = offset + i * stride;
                for j in 0..d {
                    out[i * d + j] = read_component(&bytes[at + j * cs..], ct, raw);
                }
            }
        }
        if let Some(sparse) = &acc.sparse {
            let n = to_usize(sparse.count.0)
                .filter(|&n| n <= count)
                .ok_or_else(|| err("sparse count exceeds count".into()))?;
            let Checked::Valid(ict) = sparse.indices.component_type else {
                return Err(err("unknown sparse index type".into()));
            };
            let ict = ict.0;
            if !matches!(
                ict,
                ComponentType::U8 | ComponentType::U16 | ComponentType::U32
            ) {
                return Err(err("sparse indices must be unsigned".into()));
            }
            let isz = comp_size(ict);
            let ioff = to_usize(sparse.indices.byte_offset.0)
                .ok_or_else(|| err("bad sparse offset".into()))?;
            let (ibytes, _) = self.view_bytes(sparse.indices.buffer_view.value(), index)?;
            if n.checked_mul(isz)
                .and_then(|x| x.checked_add(ioff))
                .is_none_or(|e| e > ibytes.len())
            {
                return Err(err("sparse indices do not fit in their view".into()));
            }
            let indices: Vec<usize> = (0..n)
                .map(|k| {
                    let b = &ibytes[ioff + k * isz..];
                    match ict {
                        ComponentType::U8 => b[0] as usize,
                        ComponentType::U16 => u16::from_le_bytes([b[0], b[1]]) as usize,
                        _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
                    }
                })
                .collect();
            if indices.iter().any(|&i| i >= count) || indices.windows(2).any(|w| w[1] <= w[0]) {
                return Err(err("sparse indices out of range or not increasing".into()));
            }
            let voff = to_usize(sparse.values.byte_offset.0)
                .ok_or_else(|| err("bad sparse offset".into()))?;
            let (vbytes, _) = self.view_bytes(sparse.values.buffer_view.value(), index)?;
            if n.checked_mul(elem)
                .and_then(|x| x.checked_add(voff))
                .is_none_or(|e| e > vbytes.len())
            {
                return Err(err("sparse values do not fit in their view".into()));
            }
            for (k, &i) in indices.iter().enumerate() {
                for j in 0..d {
                    out[i * d + j] = read_component(&vbytes[voff + k * elem + j * cs..], ct, raw);
                }
            }
        }
        if out.iter().any(|x| !x.is_finite()) {
            return Err(err("holds NaN or infinite values".into()));
        }
        Ok(out)
    }
}
