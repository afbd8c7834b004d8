//! NumPy `.npy` arrays and `.npz` archives: the container of Kato's published data.
//!
//! Only what datasets need: little-endian/byte dtypes, C order, format versions 1–3. `.npz` files
//! are zip archives of `.npy` members named `KEY.npy`; we write them deflate-compressed (as
//! `np.savez_compressed`) and read stored or deflated members. Hand-written over `zip` rather than
//! with `ndarray-npy`/`npyz`: those would bring ndarray or read a member whole by its claimed
//! size, where this reader checks every size against the bytes actually there and streams.

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
        Self::read_npy_from(&mut &bytes[..], bytes.len() as u64, what)
    }

    /// Reads one `.npy` array from `r`, which holds at most `max_bytes` bytes (header and data:
    /// a file's length, an archive member's bound). Every size is checked arithmetic, nothing is
    /// allocated for more data than `max_bytes` allows, and the data are read straight into the
    /// array's buffer (peak memory ≈ the array). `what` names the source in errors.
    pub fn read_npy_from(r: &mut impl Read, max_bytes: u64, what: &Path) -> Result<Self> {
        let bad = |m: String| Error::format(what, m);
        let io = |e: std::io::Error| Error::format(what, format!("cannot read: {e}"));
        let mut lead = [0u8; 10];
        if !read_full(r, &mut lead).map_err(io)? {
            return Err(bad("not a .npy array (shorter than its header)".into()));
        }
        if &lead[..6] != b"\x93NUMPY" {
            return Err(bad("not a .npy array (bad magic)".into()));
        }
        let (hlen, start) = match lead[6] {
            1 => (u16::from_le_bytes([lead[8], lead[9]]) as usize, 10usize),
            2 | 3 => {
                let mut more = [0u8; 2];
                if !read_full(r, &mut more).map_err(io)? {
                    return Err(bad("truncated .npy header".into()));
                }
                let n = u32::from_le_bytes([lead[8], lead[9], more[0], more[1]]) as usize;
                (n, 12)
            }
            v => return Err(bad(format!("unsupported .npy format version {v}"))),
        };
        if hlen > MAX_HEADER {
            return Err(bad(format!(
                "header claims {hlen} bytes (more than {MAX_HEADER}): not a NumPy header"
            )));
        }
        let mut header = vec![0u8; hlen];
        if !read_full(r, &mut header).map_err(io)? {
            return Err(bad("truncated .npy header".into()));
        }
        let header =
            std::str::from_utf8(&header).map_err(|_| bad("non-UTF-8 .npy header".into()))?;
        let (dtype, shape) = parse_header(header).map_err(bad)?;
        let expected = shape
            .iter()
            .try_fold(dtype.size(), |n, &d| n.checked_mul(d))
            .ok_or_else(|| bad(format!("shape {shape:?} overflows the address space")))?;
        let available = max_bytes.saturating_sub((start + hlen) as u64);
        if expected as u64 > available {
            return Err(bad(format!(
                "shape {shape:?} of {} needs {expected} bytes of data, but at most {available} are there",
                dtype.descr()
            )));
        }
        let mut data = Vec::new();
        data.try_reserve_exact(expected).map_err(|e| {
            bad(format!(
                "cannot allocate {expected} bytes for the array: {e}"
            ))
        })?;
        let got = r.take(expected as u64).read_to_end(&mut data).map_err(io)?;
        if got != expected {
            return Err(bad(format!(
                "data has {got} bytes, shape {shape:?} of {} needs {expected}",
                dtype.descr()
            )));
        }
        let mut extra = [0u8; 1];
        if r.read(&mut extra).map_err(io)? != 0 {
            return Err(bad(format!(
                "data runs past the {expected} bytes that shape {shape:?} of {} needs",
                dtype.descr()
            )));
        }
        Ok(Self { dtype, shape, data })
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

/// The longest header we accept (NumPy's own readers refuse far shorter ones by default).
const MAX_HEADER: usize = 1 << 20;

/// Deflate cannot expand data by more than about 1032:1, so an archive member bounds its array
/// by what it stores, whatever size it claims.
const MAX_DEFLATE_RATIO: u64 = 1032;

/// Fills `buf` from `r`; `false` if the stream ended first.
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<bool> {
    let mut at = 0;
    while at < buf.len() {
        match r.read(&mut buf[at..]) {
            Ok(0) => return Ok(false),
            Ok(n) => at += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

/// The dtype and shape of a NumPy header dict.
fn parse_header(header: &str) -> std::result::Result<(DType, Vec<usize>), String> {
    let descr =
        header_value(header, "descr").ok_or_else(|| format!("header has no 'descr': {header}"))?;
    let descr = descr
        .strip_prefix(['\'', '"'])
        .and_then(|d| d.split(['\'', '"']).next())
        .ok_or_else(|| format!("malformed 'descr' in header: {header}"))?;
    let dtype = DType::from_descr(descr).ok_or_else(|| format!("unsupported dtype '{descr}'"))?;
    if header_value(header, "fortran_order").is_some_and(|v| v.starts_with("True")) {
        return Err("Fortran-ordered arrays are not supported".into());
    }
    let shape_s =
        header_value(header, "shape").ok_or_else(|| format!("header has no 'shape': {header}"))?;
    let inner = shape_s
        .strip_prefix('(')
        .and_then(|s| s.split(')').next())
        .ok_or_else(|| format!("malformed shape '{shape_s}'"))?;
    let shape = inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>())
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|_| format!("malformed shape '{shape_s}'"))?;
    Ok((dtype, shape))
}

/// The text after `'key':` in a NumPy header dict, up to the end of the header.
fn header_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let pat = format!("'{key}'");
    let at = header.find(&pat)? + pat.len();
    let rest = header[at..].trim_start().strip_prefix(':')?;
    Some(rest.trim_start())
}

/// Writes an `.npz` archive atomically: `arrays` maps keys (`arr_0`) to arrays. The archive is
/// streamed to the file (no copy of it in memory).
pub fn write_npz(path: &Path, arrays: &[(&str, &NpyArray)]) -> Result<()> {
    super::write_atomic(path, |file| {
        let mut zip = zip::ZipWriter::new(&mut *file);
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .large_file(true);
        for (key, arr) in arrays {
            zip.start_file(format!("{key}.npy"), opts)
                .map_err(std::io::Error::other)?;
            arr.write_npy(&mut zip)?;
        }
        zip.finish().map_err(std::io::Error::other)?;
        Ok(())
    })
}

/// Opens an `.npz` archive.
fn open_npz(path: &Path) -> Result<zip::ZipArchive<std::io::BufReader<std::fs::File>>> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    zip::ZipArchive::new(std::io::BufReader::new(file))
        .map_err(|e| Error::format(path, format!("not a valid .npz (zip) archive: {e}")))
}

/// Reads one archive member (named `name`) as an array; errors name the archive and the member.
fn read_member<R: Read>(
    path: &Path,
    name: &str,
    member: &mut zip::read::ZipFile<'_, R>,
) -> Result<NpyArray> {
    // Bound what the member can hold by what it stores, not by the size it claims.
    let stored = member.compressed_size();
    let bound = match member.compression() {
        zip::CompressionMethod::Stored => stored,
        _ => stored
            .saturating_mul(MAX_DEFLATE_RATIO)
            .saturating_add(1024),
    };
    let bound = bound.min(member.size());
    NpyArray::read_npy_from(member, bound, &path.join(name))
}

/// Reads every member of an `.npz` archive.
pub fn read_npz(path: &Path) -> Result<BTreeMap<String, NpyArray>> {
    let mut zip = open_npz(path)?;
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
        let key = name.strip_suffix(".npy").unwrap_or(&name).to_string();
        let array = read_member(path, &name, &mut member)?;
        out.insert(key, array);
    }
    Ok(out)
}

/// Reads the member `key` of an `.npz` archive (only that one is decompressed); an error names
/// the file and the keys it has.
pub fn read_npz_key(path: &Path, key: &str) -> Result<NpyArray> {
    let mut zip = open_npz(path)?;
    let name = format!("{key}.npy");
    let Some(index) = zip.index_for_name(&name) else {
        let keys: Vec<String> = zip
            .file_names()
            .filter_map(|n| n.ok())
            .map(|n| n.strip_suffix(".npy").unwrap_or(&n).to_string())
            .collect();
        return Err(Error::format(
            path,
            format!("missing key '{key}' (keys present: {keys:?})"),
        ));
    };
    let mut member = zip
        .by_index(index)
        .map_err(|e| Error::format(path, format!("corrupt archive member '{name}': {e}")))?;
    read_member(path, &name, &mut member)
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

    /// A `.npy` stream with `header` (padded as NumPy does) and `data` after it.
    fn npy_with(header: &str, data: &[u8]) -> Vec<u8> {
        let mut h = header.to_string();
        while !(10 + h.len() + 1).is_multiple_of(64) {
            h.push(' ');
        }
        h.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&(h.len() as u16).to_le_bytes());
        out.extend_from_slice(h.as_bytes());
        out.extend_from_slice(data);
        out
    }

    fn error_of(bytes: &[u8]) -> String {
        NpyArray::read_npy(bytes, Path::new("f.npy"))
            .unwrap_err()
            .to_string()
    }

    /// Forged and broken headers give a clean error naming the file, before anything the
    /// header claims is allocated.
    #[test]
    fn hostile_npy_files_are_refused_with_what_is_wrong() {
        let h =
            |shape: &str| format!("{{'descr': '|u1', 'fortran_order': False, 'shape': {shape}, }}");
        // A terabyte claimed, four bytes there.
        let e = error_of(&npy_with(&h("(1099511627776,)"), &[0; 4]));
        assert!(e.contains("f.npy") && e.contains("at most"), "{e}");
        // A shape whose byte count overflows usize.
        let e = error_of(&npy_with(&h(&format!("({}, 4)", usize::MAX / 2)), &[]));
        assert!(e.contains("overflows"), "{e}");
        // Truncated data, and data past the shape.
        let e = error_of(&npy_with(&h("(2, 3)"), &[1, 2, 3]));
        assert!(e.contains("needs 6") || e.contains("at most 3"), "{e}");
        let e = error_of(&npy_with(&h("(2,)"), &[1, 2, 3]));
        assert!(e.contains("runs past"), "{e}");
        // A version-2 header that claims 4 GiB of header.
        let mut v2 = b"\x93NUMPY\x02\x00\xff\xff\xff\xff".to_vec();
        v2.extend_from_slice(b"{}");
        assert!(error_of(&v2).contains("header claims"), "{}", error_of(&v2));
        // Bad magic, a cut-off file, nonsense in the header.
        assert!(error_of(b"PK\x03\x04 not numpy at all").contains("bad magic"));
        assert!(error_of(b"\x93NUM").contains("shorter than its header"));
        let e = error_of(&npy_with("{'descr': '<c16', 'shape': (1,)}", &[0; 16]));
        assert!(e.contains("unsupported dtype"), "{e}");
        let e = error_of(&npy_with(&h("(2, x)"), &[]));
        assert!(e.contains("malformed shape"), "{e}");
        // And a well-formed one still reads.
        let a = NpyArray::read_npy(&npy_with(&h("(2, 2)"), &[1, 2, 3, 4]), Path::new("f"));
        assert_eq!(a.unwrap().data, [1, 2, 3, 4]);
    }

    /// The requested member is read by name: a corrupt sibling does not stop it (it does stop
    /// reading the whole archive, with the sibling named), and a member whose header claims more
    /// than it stores is refused naming the archive and the member.
    #[test]
    fn npz_members_are_read_by_name_and_bounded_by_what_they_store() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("mixed.npz");
        let good = NpyArray::from_u8(vec![4], vec![9, 8, 7, 6]);
        let mut bytes = Vec::new();
        good.write_npy(&mut bytes).unwrap();
        let forged = npy_with(
            "{'descr': '|u1', 'fortran_order': False, 'shape': (1099511627776,), }",
            &[0; 8],
        );
        let file = std::fs::File::create(&p).unwrap();
        let mut zip = zip::ZipWriter::new(file);
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        for (name, data) in [
            ("arr_0.npy", &bytes[..]),
            ("junk.npy", &b"garbage"[..]),
            ("big.npy", &forged[..]),
        ] {
            zip.start_file(name, opts).unwrap();
            zip.write_all(data).unwrap();
        }
        zip.finish().unwrap();
        assert_eq!(read_npz_key(&p, "arr_0").unwrap(), good);
        let e = read_npz_key(&p, "big").unwrap_err().to_string();
        assert!(
            e.contains("mixed.npz") && e.contains("big.npy") && e.contains("at most"),
            "{e}"
        );
        let e = read_npz(&p).unwrap_err().to_string();
        assert!(
            e.contains("junk.npy") && e.contains("not a .npy array"),
            "{e}"
        );
    }
}
