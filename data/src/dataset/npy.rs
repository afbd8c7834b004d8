//! NumPy `.npy` arrays and `.npz` archives: the container of Kato's published data.
//!
//! Only what datasets need: little-endian/byte dtypes, C order, format versions 1–3. `.npz` files
//! are zip archives of `.npy` members named `KEY.npy`; we write them deflate-compressed (as
//! `np.savez_compressed`) and read stored or deflated members.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::Path;

use crate::{Error, Result};

/// The element types we read and write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DType {
    U8,
    Bool,
    F32,
    F64,
    I64,
}

impl DType {
    /// NumPy's `descr` string.
    pub fn descr(self) -> &'static str {
        match self {
            DType::U8 => "|u1",
            DType::Bool => "|b1",
            DType::F32 => "<f4",
            DType::F64 => "<f8",
            DType::I64 => "<i8",
        }
    }

    fn from_descr(s: &str) -> Option<Self> {
        match s {
            "|u1" | "<u1" | "u1" => Some(DType::U8),
            "|b1" | "<b1" | "b1" => Some(DType::Bool),
            "<f4" => Some(DType::F32),
            "<f8" => Some(DType::F64),
            "<i8" => Some(DType::I64),
            _ => None,
        }
    }

    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            DType::U8 | DType::Bool => 1,
            DType::F32 => 4,
            DType::F64 | DType::I64 => 8,
        }
    }
}

/// A C-ordered array with raw little-endian data.
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    pub dtype: DType,
    pub shape: Vec<usize>,
    pub data: Vec<u8>,
}

impl NpyArray {
    pub fn from_u8(shape: Vec<usize>, data: Vec<u8>) -> Self {
        assert_eq!(shape.iter().product::<usize>(), data.len());
        Self {
            dtype: DType::U8,
            shape,
            data,
        }
    }

    pub fn from_bool(shape: Vec<usize>, data: &[bool]) -> Self {
        assert_eq!(shape.iter().product::<usize>(), data.len());
        Self {
            dtype: DType::Bool,
            shape,
            data: data.iter().map(|&b| b as u8).collect(),
        }
    }

    pub fn from_f32(shape: Vec<usize>, data: &[f32]) -> Self {
        assert_eq!(shape.iter().product::<usize>(), data.len());
        Self {
            dtype: DType::F32,
            shape,
            data: data.iter().flat_map(|v| v.to_le_bytes()).collect(),
        }
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.shape.iter().product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Values as `f64`, whatever the stored float/int type.
    pub fn to_f64(&self) -> Vec<f64> {
        let c = self.data.chunks_exact(self.dtype.size());
        match self.dtype {
            DType::U8 | DType::Bool => self.data.iter().map(|&b| b as f64).collect(),
            DType::F32 => c
                .map(|b| f32::from_le_bytes(b.try_into().unwrap()) as f64)
                .collect(),
            DType::F64 => c
                .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
                .collect(),
            DType::I64 => c
                .map(|b| i64::from_le_bytes(b.try_into().unwrap()) as f64)
                .collect(),
        }
    }

    /// Serializes as `.npy` (format 1.0, header padded to 64 bytes as NumPy does).
    pub fn write_npy(&self, w: &mut impl Write) -> std::io::Result<()> {
        let shape = match self.shape.len() {
            1 => format!("({},)", self.shape[0]),
            _ => format!(
                "({})",
                self.shape
                    .iter()
                    .map(|s| s.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        let mut header = format!(
            "{{'descr': '{}', 'fortran_order': False, 'shape': {}, }}",
            self.dtype.descr(),
            shape
        );
        let total = 10 + header.len() + 1;
        header.push_str(&" ".repeat((64 - total % 64) % 64));
        header.push('\n');
        w.write_all(b"\x93NUMPY\x01\x00")?;
        w.write_all(&(header.len() as u16).to_le_bytes())?;
        w.write_all(header.as_bytes())?;
        w.write_all(&self.data)
    }

    /// Parses a `.npy` byte stream; `what` names the source in errors.
    pub fn read_npy(bytes: &[u8], what: &Path) -> Result<Self> {
        let bad = |m: String| Error::format(what, m);
        if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
            return Err(bad("not a .npy array (bad magic)".into()));
        }
        let (hlen, start) = match bytes[6] {
            1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
            2 | 3 if bytes.len() >= 12 => (
                u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
                12,
            ),
            v => return Err(bad(format!("unsupported .npy format version {v}"))),
        };
        let header = bytes
            .get(start..start + hlen)
            .and_then(|h| std::str::from_utf8(h).ok())
            .ok_or_else(|| bad("truncated or non-UTF-8 .npy header".into()))?;
        let descr = header_value(header, "descr")
            .ok_or_else(|| bad(format!("header has no 'descr': {header}")))?;
        let descr = descr
            .strip_prefix(['\'', '"'])
            .and_then(|d| d.split(['\'', '"']).next())
            .ok_or_else(|| bad(format!("malformed 'descr' in header: {header}")))?;
        let dtype =
            DType::from_descr(descr).ok_or_else(|| bad(format!("unsupported dtype '{descr}'")))?;
        if header_value(header, "fortran_order").is_some_and(|v| v.starts_with("True")) {
            return Err(bad("Fortran-ordered arrays are not supported".into()));
        }
        let shape_s = header_value(header, "shape")
            .ok_or_else(|| bad(format!("header has no 'shape': {header}")))?;
        let inner = shape_s
            .strip_prefix('(')
            .and_then(|s| s.split(')').next())
            .ok_or_else(|| bad(format!("malformed shape '{shape_s}'")))?;
        let shape = inner
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<usize>())
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(|_| bad(format!("malformed shape '{shape_s}'")))?;
        let data = &bytes[start + hlen..];
        let expected = shape.iter().product::<usize>() * dtype.size();
        if data.len() != expected {
            return Err(bad(format!(
                "data has {} bytes, shape {:?} of {} needs {}",
                data.len(),
                shape,
                descr,
                expected
            )));
        }
        Ok(Self {
            dtype,
            shape,
            data: data.to_vec(),
        })
    }

    /// Checks dtype and shape, with an error naming `file` and `key`. A `None` in `shape` matches
    /// any length.
    pub fn expect(
        &self,
        file: &Path,
        key: &str,
        dtype: DType,
        shape: &[Option<usize>],
    ) -> Result<()> {
        let ok_shape = self.shape.len() == shape.len()
            && self
                .shape
                .iter()
                .zip(shape)
                .all(|(a, b)| b.is_none_or(|b| *a == b));
        if self.dtype != dtype || !ok_shape {
            let want: Vec<String> = shape
                .iter()
                .map(|s| s.map_or("N".into(), |v| v.to_string()))
                .collect();
            return Err(Error::format(
                file,
                format!(
                    "key '{key}': expected {} with shape ({}), found {} with shape {:?}",
                    dtype.descr(),
                    want.join(", "),
                    self.dtype.descr(),
                    self.shape
                ),
            ));
        }
        Ok(())
    }
}

/// The text after `'key':` in a NumPy header dict, up to the end of the header.
fn header_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let pat = format!("'{key}'");
    let at = header.find(&pat)? + pat.len();
    let rest = header[at..].trim_start().strip_prefix(':')?;
    Some(rest.trim_start())
}

/// Writes an `.npz` archive atomically: `arrays` maps keys (`arr_0`) to arrays.
pub fn write_npz(path: &Path, arrays: &[(&str, &NpyArray)]) -> Result<()> {
    super::write_atomic(path, |file| {
        let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .large_file(true);
        for (key, arr) in arrays {
            zip.start_file(format!("{key}.npy"), opts)
                .map_err(std::io::Error::other)?;
            arr.write_npy(&mut zip)?;
        }
        let buf = zip.finish().map_err(std::io::Error::other)?.into_inner();
        file.write_all(&buf)
    })
}

/// Reads every member of an `.npz` archive.
pub fn read_npz(path: &Path) -> Result<BTreeMap<String, NpyArray>> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut zip = zip::ZipArchive::new(std::io::BufReader::new(file))
        .map_err(|e| Error::format(path, format!("not a valid .npz (zip) archive: {e}")))?;
    let mut out = BTreeMap::new();
    for i in 0..zip.len() {
        let mut member = zip
            .by_index(i)
            .map_err(|e| Error::format(path, format!("corrupt archive member {i}: {e}")))?;
        let name = member
            .name()
            .map_err(|e| {
                Error::format(path, format!("archive member {i} has an invalid name: {e}"))
            })?
            .to_string();
        let mut bytes = Vec::with_capacity(member.size() as usize);
        member.read_to_end(&mut bytes).map_err(|e| {
            Error::format(path, format!("member '{name}' cannot be decompressed: {e}"))
        })?;
        let key = name.strip_suffix(".npy").unwrap_or(&name).to_string();
        let arr = NpyArray::read_npy(&bytes, &path.join(&name))?;
        out.insert(key, arr);
    }
    Ok(out)
}

/// Reads the member `key` of an `.npz` archive; an error names the file and the keys it has.
pub fn read_npz_key(path: &Path, key: &str) -> Result<NpyArray> {
    let mut all = read_npz(path)?;
    all.remove(key).ok_or_else(|| {
        let keys: Vec<_> = all.keys().cloned().collect();
        Error::format(
            path,
            format!("missing key '{key}' (keys present: {keys:?})"),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_64_byte_aligned_and_round_trips() {
        let a = NpyArray::from_u8(vec![2, 3], vec![1, 2, 3, 4, 5, 6]);
        let mut buf = Vec::new();
        a.write_npy(&mut buf).unwrap();
        assert_eq!((buf.len() - 6) % 64, 0);
        let b = NpyArray::read_npy(&buf, Path::new("x.npy")).unwrap();
        assert_eq!(a, b);
        let one = NpyArray::from_f32(vec![3], &[1.0, -2.5, 3.0]);
        let mut buf = Vec::new();
        one.write_npy(&mut buf).unwrap();
        assert!(String::from_utf8_lossy(&buf).contains("'shape': (3,)"));
        assert_eq!(
            NpyArray::read_npy(&buf, Path::new("x")).unwrap().to_f64(),
            vec![1.0, -2.5, 3.0]
        );
    }

    #[test]
    fn npz_round_trip_and_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.npz");
        let a = NpyArray::from_bool(vec![2, 2], &[true, false, false, true]);
        write_npz(&p, &[("arr_0", &a)]).unwrap();
        assert_eq!(read_npz_key(&p, "arr_0").unwrap(), a);
        let e = read_npz_key(&p, "arr_1").unwrap_err().to_string();
        assert!(
            e.contains("a.npz") && e.contains("arr_1") && e.contains("arr_0"),
            "{e}"
        );
        let e = a
            .expect(&p, "arr_0", DType::U8, &[None, Some(2)])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("a.npz") && e.contains("|u1") && e.contains("|b1"),
            "{e}"
        );

        let corrupt = dir.path().join("corrupt.npz");
        std::fs::write(&corrupt, b"PK\x03\x04 this is not a zip").unwrap();
        let e = read_npz(&corrupt).unwrap_err().to_string();
        assert!(e.contains("corrupt.npz"), "{e}");
    }
}
