//! The tests of `ssm::mat`.

use ssm::mat::*;

// The MAT v5 format's codes, written out here from the format's documentation (the test
// files are built independently of the reader's own table).
const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_DOUBLE: u32 = 9;
const MI_MATRIX: u32 = 14;
const MX_CELL: u8 = 1;
const MX_DOUBLE: u8 = 6;
const FLAG_COMPLEX: u32 = 0x0800;

/// A header, then `elements` (already tagged and padded).
fn file(elements: &[u8]) -> Vec<u8> {
    let mut b = b"MATLAB 5.0 MAT-file, written by the ssm tests".to_vec();
    b.resize(124, b' ');
    b.extend_from_slice(&0x0100u16.to_le_bytes());
    b.extend_from_slice(b"IM");
    b.extend_from_slice(elements);
    b
}

fn element(ty: u32, data: &[u8]) -> Vec<u8> {
    let mut b = ty.to_le_bytes().to_vec();
    b.extend_from_slice(&(data.len() as u32).to_le_bytes());
    b.extend_from_slice(data);
    b.resize(8 + data.len().div_ceil(8) * 8, 0);
    b
}

fn small(ty: u32, data: &[u8]) -> Vec<u8> {
    let mut b = (ty | (data.len() as u32) << 16).to_le_bytes().to_vec();
    b.extend_from_slice(data);
    b.resize(8, 0);
    b
}

/// An miMATRIX of `class` with `flags`, dims and name, then `rest` sub-elements.
fn matrix(class: u8, flags: u32, dims: &[i32], name: &str, rest: &[u8]) -> Vec<u8> {
    let mut body = element(MI_UINT32, &[(class as u32 | flags).to_le_bytes(), [0; 4]].concat());
    body.extend(element(MI_INT32, &dims.iter().flat_map(|d| d.to_le_bytes()).collect::<Vec<_>>()));
    body.extend(if name.len() <= 4 { small(MI_INT8, name.as_bytes()) } else { element(MI_INT8, name.as_bytes()) });
    body.extend_from_slice(rest);
    element(MI_MATRIX, &body)
}

#[test]
fn integer_storage_small_elements_and_cells() {
    // MATLAB stores integral doubles in the smallest integer type; a small element
    // holds up to 4 bytes.
    let a = matrix(MX_DOUBLE, 0, &[1, 3], "", &element(MI_UINT8, &[1, 2, 250]));
    let b = matrix(MX_DOUBLE, 0, &[1, 1], "", &small(MI_INT16, &(-7i16).to_le_bytes()));
    let c = matrix(MX_CELL, 0, &[2, 1], "cc", &[a, b].concat());
    let m = MatFile::parse("mem.mat", &file(&c)).unwrap();
    assert_eq!(m.names(), ["cc"]);
    let MatValue::Cell { dims, cells } = m.get("cc").unwrap() else { panic!("not a cell") };
    assert_eq!(dims, [2, 1]);
    assert_eq!(cells[0], MatValue::Double { dims: [1, 3], data: vec![1.0, 2.0, 250.0] });
    assert_eq!(cells[1], MatValue::Double { dims: [1, 1], data: vec![-7.0] });
}

#[test]
fn errors_name_the_variable_and_cell() {
    let check = |bytes: &[u8], var: &str, want: &str| {
        let e = MatFile::parse("m.mat", bytes).and_then(|m| m.get(var).map(|_| ())).unwrap_err();
        assert!(e.to_string().contains(want), "{e} (want {want})");
    };
    let cplx = matrix(
        MX_DOUBLE,
        FLAG_COMPLEX,
        &[1, 1],
        "",
        &[element(MI_DOUBLE, &1f64.to_le_bytes()), element(MI_DOUBLE, &2f64.to_le_bytes())].concat(),
    );
    let chr = matrix(4, 0, &[1, 2], "", &element(16, b"ab"));
    let ok = matrix(MX_DOUBLE, 0, &[1, 1], "", &element(MI_DOUBLE, &1f64.to_le_bytes()));
    let cell = matrix(MX_CELL, 0, &[1, 3], "xData", &[ok.clone(), cplx, chr.clone()].concat());
    check(&file(&cell), "xData", "xData{1,2}: a complex double array");
    let cell = matrix(MX_CELL, 0, &[1, 2], "xData", &[ok.clone(), chr].concat());
    check(&file(&cell), "xData", "xData{1,2}: class char");
    let st = matrix(2, 0, &[1, 1], "info", &[]);
    check(&file(&st), "info", "info: class struct");
    let nd = matrix(MX_DOUBLE, 0, &[1, 1, 1], "cube", &element(MI_DOUBLE, &1f64.to_le_bytes()));
    check(&file(&nd), "cube", "3-dimensional double");
    check(&file(&ok), "xData", "no variable `xData` (variables: )");
    let short = matrix(MX_DOUBLE, 0, &[2, 2], "x", &element(MI_DOUBLE, &1f64.to_le_bytes()));
    check(&file(&short), "x", "x: truncated or malformed (1 values for dimensions 2x2)");
    let mut cut = file(&ok);
    cut.truncate(cut.len() - 3);
    check(&cut, "", "variable #1: truncated");
    // Header problems.
    let mut be = file(&ok);
    be[126..128].copy_from_slice(b"MI");
    check(&be, "", "big-endian");
    check(b"hello", "", "not a MATLAB v5 .mat file");
    check(&[0u8; 200], "", "a v4 file or not a .mat file");
    let mut other_text = file(&ok);
    other_text[..6].copy_from_slice(b"Octave");
    assert!(MatFile::parse("m.mat", &other_text).is_ok());
    let mut v73 =
        b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 .".to_vec();
    v73.resize(512, b' ');
    v73.extend_from_slice(b"\x89HDF\r\n\x1a\n");
    check(&v73, "", "v7.3 (HDF5)");
    check(&v73, "", "'-v7'");
}
