//! The bytes around the glTF document: the .glb container, the JSON pre-pass that works around
//! what `gltf` 1.4.1 rejects, and the buffers (GLB binary chunk, base64 data URIs, files next to a
//! .gltf). Images are never touched.

use std::borrow::Cow;
use std::path::{Component, Path};

use base64::alphabet;
use base64::engine::{DecodePaddingMode, Engine, GeneralPurpose, GeneralPurposeConfig};
use serde_json::Value;

use crate::error::ImportError;

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a file into its JSON text and, for a .glb, its binary chunk.
pub(crate) fn split(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), ImportError> {
    if !bytes.starts_with(GLB_MAGIC) {
        let json = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        return Ok((json, None));
    }
    let bad = |m: String| ImportError::Container(m);
    let version = u32_at(bytes, 4).ok_or_else(|| bad("header shorter than 12 bytes".into()))?;
    if version != 2 {
        return Err(bad(format!("version {version}, expected 2")));
    }
    let length =
        u32_at(bytes, 8).ok_or_else(|| bad("header shorter than 12 bytes".into()))? as usize;
    if length > bytes.len() {
        return Err(bad(format!(
            "header declares {length} bytes but the file has {}",
            bytes.len()
        )));
    }
    let bytes = &bytes[..length];
    let mut at = 12usize;
    let mut json = None;
    let mut bin = None;
    while at < length {
        let (Some(len), Some(kind)) = (u32_at(bytes, at), u32_at(bytes, at + 4)) else {
            return Err(bad(format!("truncated chunk header at byte {at}")));
        };
        let start = at + 8;
        let end = start
            .checked_add(len as usize)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                bad(format!(
                    "chunk at byte {at} declares {len} bytes past the end"
                ))
            })?;
        match kind {
            CHUNK_JSON if json.is_none() && at == 12 => json = Some(&bytes[start..end]),
            CHUNK_JSON => return Err(bad("JSON chunk is not the first chunk".into())),
            CHUNK_BIN if bin.is_none() && json.is_some() => bin = Some(&bytes[start..end]),
            CHUNK_BIN => return Err(bad("misplaced or repeated BIN chunk".into())),
            _ => {} // Unknown chunk types are skipped, as the spec asks.
        }
        // Chunks are 4-byte aligned; tolerate a missing pad at the very end.
        at = ((end + 3) & !3).min(length);
    }
    let json = json.ok_or_else(|| bad("no JSON chunk".into()))?;
    Ok((json, bin))
}

/// Extensions whose presence in `extensionsRequired` means animation or skin data is stored in a
/// way this importer cannot read.
const UNREADABLE_EXTENSIONS: &[&str] = &["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// Parses the JSON and repairs what `gltf` 1.4.1 rejects although glTF allows it or it does not
/// concern animation: a scene without a `nodes` list gets an empty one, and
/// `KHR_mesh_quantization` (which only widens the mesh attribute types; we read no mesh) is
/// dropped from `extensionsRequired`. Other required extensions that only concern meshes,
/// materials or textures are dropped too; those that compress buffers are refused.
pub(crate) fn prepass(json: &[u8]) -> Result<Value, ImportError> {
    let mut value: Value =
        serde_json::from_slice(json).map_err(|e| ImportError::Json(e.to_string()))?;
    let obj = value
        .as_object_mut()
        .ok_or_else(|| ImportError::Json("top level is not an object".into()))?;
    if let Some(scenes) = obj.get_mut("scenes").and_then(Value::as_array_mut) {
        for scene in scenes.iter_mut().filter_map(Value::as_object_mut) {
            scene
                .entry("nodes")
                .or_insert_with(|| Value::Array(Vec::new()));
        }
    }
    if let Some(req) = obj
        .get_mut("extensionsRequired")
        .and_then(Value::as_array_mut)
    {
        for ext in req.iter().filter_map(Value::as_str) {
            if UNREADABLE_EXTENSIONS.contains(&ext) {
                return Err(ImportError::UnsupportedExtension(ext.to_string()));
            }
        }
        req.clear();
    }
    Ok(value)
}

/// Standard and URL-safe base64, padding optional, trailing bits not checked: what glTF writers
/// put in data URIs (RFC 2397 asks for the standard alphabet; some tools write the URL-safe one).
const BASE64_CONFIG: GeneralPurposeConfig = GeneralPurposeConfig::new()
    .with_decode_padding_mode(DecodePaddingMode::Indifferent)
    .with_decode_allow_trailing_bits(true);
const BASE64_STANDARD: GeneralPurpose = GeneralPurpose::new(&alphabet::STANDARD, BASE64_CONFIG);
const BASE64_URL_SAFE: GeneralPurpose = GeneralPurpose::new(&alphabet::URL_SAFE, BASE64_CONFIG);

/// Decodes standard (or URL-safe) base64, with or without padding.
///
/// `gltf` 1.4.1 decodes data URIs only in `gltf::import`, behind its `import` feature (which also
/// pulls in the `image` crate and loads images); we build it without default features and read
/// the buffers ourselves, so the decoding is here, done by the `base64` crate.
pub(crate) fn decode_base64(text: &str) -> Option<Vec<u8>> {
    BASE64_STANDARD
        .decode(text)
        .or_else(|_| BASE64_URL_SAFE.decode(text))
        .ok()
}

/// Percent-decodes a relative URI into a UTF-8 path; `None` for a `%` not followed by two hex
/// digits or for bytes that are not UTF-8 (the `percent-encoding` crate itself passes malformed
/// escapes through unchanged, so they are refused here first).
fn percent_decode(s: &str) -> Option<String> {
    let well_formed = s.match_indices('%').all(|(i, _)| {
        s.as_bytes()
            .get(i + 1..i + 3)
            .is_some_and(|hex| hex.iter().all(u8::is_ascii_hexdigit))
    });
    if !well_formed {
        return None;
    }
    percent_encoding::percent_decode_str(s)
        .decode_utf8()
        .ok()
        .map(Cow::into_owned)
}

/// Loads the bytes of one buffer: the GLB binary chunk, a data URI, or a file relative to
/// `base`. Relative paths may not leave `base` (no `..`, no absolute paths, no other schemes).
pub(crate) fn load_buffer<'a>(
    index: usize,
    uri: Option<&str>,
    byte_length: u64,
    bin: Option<&'a [u8]>,
    base: Option<&Path>,
) -> Result<Cow<'a, [u8]>, ImportError> {
    let err = |reason: String| ImportError::Buffer { index, reason };
    let data: Cow<'a, [u8]> = match uri {
        None => match bin {
            Some(b) if index == 0 => Cow::Borrowed(b),
            _ => return Err(err("no URI and no GLB binary chunk for it".into())),
        },
        Some(uri) if uri.starts_with("data:") => {
            let (_, payload) = uri
                .split_once(";base64,")
                .ok_or_else(|| err("data URI is not base64".into()))?;
            Cow::Owned(decode_base64(payload).ok_or_else(|| err("invalid base64".into()))?)
        }
        Some(uri) => {
            let base = base.ok_or_else(|| {
                err(format!(
                    "refers to file {uri:?} but no base directory was given"
                ))
            })?;
            let rel =
                percent_decode(uri).ok_or_else(|| err("invalid percent-encoding in URI".into()))?;
            let rel_path = Path::new(&rel);
            let escapes = rel.contains("://")
                || rel_path
                    .components()
                    .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir));
            if escapes {
                return Err(err(format!("URI {uri:?} leaves the base directory")));
            }
            let path = base.join(rel_path);
            Cow::Owned(std::fs::read(&path).map_err(|source| ImportError::Io { path, source })?)
        }
    };
    if (data.len() as u64) < byte_length {
        return Err(err(format!(
            "declares {byte_length} bytes but holds {}",
            data.len()
        )));
    }
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_roundtrip() {
        assert_eq!(decode_base64("TWFu").unwrap(), b"Man");
        assert_eq!(decode_base64("TWE=").unwrap(), b"Ma");
        assert_eq!(decode_base64("TQ==").unwrap(), b"M");
        assert_eq!(decode_base64("").unwrap(), b"");
        assert!(decode_base64("T!==").is_none());
        assert!(decode_base64("T").is_none());
        assert_eq!(decode_base64("TWE").unwrap(), b"Ma");
        assert_eq!(decode_base64("-_8=").unwrap(), [0xfb, 0xff]);
        assert_eq!(decode_base64("+/8").unwrap(), [0xfb, 0xff]);
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b/c%2Ebin").unwrap(), "a b/c.bin");
        assert_eq!(percent_decode("plain.bin").unwrap(), "plain.bin");
        for bad in ["a%zz.bin", "a%4", "%", "%FF"] {
            assert!(percent_decode(bad).is_none(), "{bad}");
        }
    }

    #[test]
    fn prepass_adds_scene_nodes_and_drops_quantization() {
        let v = prepass(
            br#"{"asset":{"version":"2.0"},"scenes":[{"name":"a"},{"nodes":[0]}],
            "extensionsRequired":["KHR_mesh_quantization"]}"#,
        )
        .unwrap();
        assert_eq!(v["scenes"][0]["nodes"], serde_json::json!([]));
        assert_eq!(v["scenes"][1]["nodes"], serde_json::json!([0]));
        assert_eq!(v["extensionsRequired"], serde_json::json!([]));
        let e = prepass(br#"{"extensionsRequired":["EXT_meshopt_compression"]}"#).unwrap_err();
        assert!(matches!(e, ImportError::UnsupportedExtension(_)));
        assert!(matches!(prepass(b"[1,2]"), Err(ImportError::Json(_))));
    }

    #[test]
    fn glb_container_checks() {
        let mut glb = Vec::new();
        let json = br#"{"asset":{"version":"2.0"}}"#;
        let pad = (4 - json.len() % 4) % 4;
        let total = 12 + 8 + json.len() + pad;
        glb.extend_from_slice(b"glTF");
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&(total as u32).to_le_bytes());
        glb.extend_from_slice(&((json.len() + pad) as u32).to_le_bytes());
        glb.extend_from_slice(&CHUNK_JSON.to_le_bytes());
        glb.extend_from_slice(json);
        glb.extend(std::iter::repeat_n(b' ', pad));
        let (j, b) = split(&glb).unwrap();
        assert!(j.starts_with(json));
        assert!(b.is_none());
        for cut in [4, 11, 15, 25, total - 1] {
            assert!(
                matches!(split(&glb[..cut]), Err(ImportError::Container(_))),
                "cut {cut}"
            );
        }
        let mut v1 = glb.clone();
        v1[4] = 1;
        assert!(split(&v1).is_err());
    }

    #[test]
    fn relative_uris_stay_inside_the_base() {
        let base = Path::new("/nonexistent");
        for uri in ["../x.bin", "/etc/passwd", "http://a/b.bin", "a/../../b"] {
            let e = load_buffer(0, Some(uri), 0, None, Some(base)).unwrap_err();
            assert!(matches!(e, ImportError::Buffer { .. }), "{uri}: {e}");
        }
        assert!(matches!(
            load_buffer(0, Some("x.bin"), 0, None, None),
            Err(ImportError::Buffer { .. })
        ));
        let ok = load_buffer(
            0,
            Some("data:application/octet-stream;base64,AAEC"),
            3,
            None,
            None,
        )
        .unwrap();
        assert_eq!(&*ok, &[0u8, 1, 2]);
        assert!(
            load_buffer(
                0,
                Some("data:application/octet-stream;base64,AAEC"),
                4,
                None,
                None
            )
            .is_err()
        );
    }
}
