//! The NMR camera and voxel layout against `nmr_camera_golden.json`, which was computed
//! independently of this project from the formulas in DESIGN.md §4.

use fieldprobe_core::data::GridFrame;
use fieldprobe_core::data::dataset::kato::voxels_from_file_layout;
use fieldprobe_core::geometry::{Camera, NUM_VIEWS};
use glam::Vec3;
use serde_json::Value;

fn golden() -> Value {
    let path = fieldprobe_tests::data_dir().join("nmr_camera_golden.json");
    serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap()
}

fn vec3(v: &Value) -> Vec3 {
    let a: Vec<f32> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap() as f32)
        .collect();
    Vec3::new(a[0], a[1], a[2])
}

fn f(v: &Value) -> f32 {
    v.as_f64().unwrap() as f32
}

#[test]
fn cameras_match_the_golden_file_in_all_24_views() {
    let g = golden();
    let views = g["views"].as_array().unwrap();
    assert_eq!(views.len(), NUM_VIEWS);
    let mut checked = 0;
    for view in views {
        let cam = Camera::nmr(view["view"].as_u64().unwrap() as usize);
        for (field, ours) in [
            ("eye", cam.eye),
            ("right", cam.right),
            ("up", cam.up),
            ("forward", cam.forward),
        ] {
            let want = vec3(&view[field]);
            assert!(
                (ours - want).length() < 2e-5,
                "view {} {field}: {ours:?} vs {want:?}",
                view["view"]
            );
        }
        for p in view["projections"].as_array().unwrap() {
            let point = vec3(&p["point"]);
            let (ndc, depth) = cam.project_ndc(point);
            let (px, _) = cam.project(point);
            let ndc_want = vec3(&Value::from(vec![
                p["ndc"][0].clone(),
                p["ndc"][1].clone(),
                Value::from(0.0),
            ]));
            assert!(
                (ndc.x - ndc_want.x).abs() < 2e-5 && (ndc.y - ndc_want.y).abs() < 2e-5,
                "{p}"
            );
            assert!((depth - f(&p["depth"])).abs() < 2e-5, "{p}");
            assert!(
                (px.col - f(&p["col"])).abs() < 1e-3 && (px.row - f(&p["row"])).abs() < 1e-3,
                "{p}"
            );
            checked += 1;
        }
    }
    assert!(checked >= NUM_VIEWS * 5);
}

#[test]
fn file_voxel_indices_map_to_the_golden_world_centres() {
    let g = golden();
    let r = 32;
    let frame = GridFrame::new(r);
    for s in g["voxels"]["samples"].as_array().unwrap() {
        let idx: Vec<usize> = s["index"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap() as usize)
            .collect();
        // Put a single voxel at file index [a][b][c] and find where it lands in world axes.
        let mut file = vec![false; r * r * r];
        file[(idx[0] * r + idx[1]) * r + idx[2]] = true;
        let grid = voxels_from_file_layout(&file, r);
        let at = grid.data.iter().position(|&b| b).unwrap();
        let (i, j, k) = (at / (r * r), (at / r) % r, at % r);
        let centre = frame.centre(i, j, k);
        let want = vec3(&s["world"]);
        assert!(
            (centre - want).length() < 1e-5,
            "{idx:?}: {centre:?} vs {want:?}"
        );
    }
}
