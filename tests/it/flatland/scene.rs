//! Flatland scene validation: every refusal names the file, the place, what was
//! expected and what was found; the minimal scene of the format loads.

use std::path::Path;

use rhier::Error;
use rhier::flatland::scene::parse;

fn err(text: &str) -> (String, String, String) {
    match parse(Path::new("scene.json"), text) {
        Err(Error::Invalid {
            path,
            place,
            expected,
            found,
        }) => {
            assert_eq!(path, Path::new("scene.json"));
            (place, expected, found)
        }
        other => panic!("expected Invalid, got {other:?}"),
    }
}

const SEG_OK: &str = r#"{"a": [0, 0], "b": [1, 0], "reflectance": 0.5}"#;

fn one(seg: &str) -> String {
    format!(r#"{{"rhier_flatland": 1, "objects": [{{"name": "room", "segments": [{seg}]}}]}}"#)
}

#[test]
fn minimal_scene_of_the_format_loads() {
    let text = r#"{"rhier_flatland": 1,
        "objects": [{"name": "room",
                     "segments": [{"a": [0,0], "b": [1,0], "reflectance": 0.75, "emission": 0.0}],
                     "motion": [{"t": 0.0, "translation": [0,0], "rotation": 0.0}]}]}"#;
    let s = parse(Path::new("x"), text).unwrap();
    assert_eq!(s.segment_count(), 1);
    assert!(s.grey);
    assert_eq!(s.objects[0].segments[0].rho, [0.75; 3]);
    let rgb = parse(
        Path::new("x"),
        &one(r#"{"a": [0, 0], "b": [1, 0], "reflectance": [0.1, 0.2, 0.3], "emission": 2}"#),
    )
    .unwrap();
    assert!(!rgb.grey);
    assert_eq!(rgb.objects[0].segments[0].rho, [0.1, 0.2, 0.3]);
    assert_eq!(rgb.objects[0].segments[0].emission, [2.0; 3]);
}

#[test]
fn crossing_segments_are_refused() {
    let (place, expected, found) = err(&one(&format!(
        r#"{SEG_OK}, {{"a": [0.5, -1], "b": [0.5, 1], "reflectance": 0.5}}"#
    )));
    assert!(place.contains("object \"room\", segment 0") && place.contains("segment 1"));
    assert!(expected.contains("do not cross"));
    assert_eq!(found, "crossing segments");
    // Collinear overlap counts as crossing; shared endpoints do not.
    err(&one(&format!(
        r#"{SEG_OK}, {{"a": [0.5, 0], "b": [2, 0]}}"#
    )));
    parse(
        Path::new("x"),
        &one(&format!(r#"{SEG_OK}, {{"a": [1, 0], "b": [1, 1]}}"#)),
    )
    .unwrap();
}

#[test]
fn crossing_caused_by_motion_is_refused_at_its_keyframe() {
    let text = r#"{"rhier_flatland": 1, "objects": [
        {"name": "wall", "segments": [{"a": [0, 0], "b": [0, 2]}]},
        {"name": "bar", "segments": [{"a": [1, 1], "b": [2, 1]}],
         "motion": [{"t": 0, "translation": [0, 0]}, {"t": 1, "translation": [-1.5, 0]}]}]}"#;
    let (place, _, _) = err(text);
    assert!(place.contains("t = 1"), "{place}");
    assert!(place.contains("object \"bar\""), "{place}");
}

#[test]
fn zero_length_segment_is_refused() {
    let (place, expected, found) = err(&one(r#"{"a": [1, 2], "b": [1, 2]}"#));
    assert_eq!(place, "object \"room\", segment 0");
    assert!(expected.contains("non-zero length"));
    assert!(found.contains("[1, 2]"));
}

#[test]
fn reflectance_outside_unit_interval_is_refused() {
    for bad in ["1.0", "-0.1", "[0.5, 1.2, 0.5]"] {
        let (place, expected, found) = err(&one(&format!(
            r#"{{"a": [0, 0], "b": [1, 0], "reflectance": {bad}}}"#
        )));
        assert_eq!(place, "object \"room\", segment 0, \"reflectance\"");
        assert_eq!(expected, "values in [0, 1)");
        assert!(["1", "-0.1", "1.2"].contains(&found.as_str()), "{found}");
    }
}

#[test]
fn negative_or_malformed_emission_is_refused() {
    let (place, _, found) = err(&one(r#"{"a": [0, 0], "b": [1, 0], "emission": -1}"#));
    assert!(place.ends_with("\"emission\""));
    assert_eq!(found, "-1");
    let (_, expected, found) = err(&one(r#"{"a": [0, 0], "b": [1, 0], "emission": [1, 2]}"#));
    assert!(expected.contains("RGB triple"));
    assert!(found.contains("2 items"));
    let (_, _, found) = err(&one(r#"{"a": [0, 0], "b": [1, 0], "emission": "bright"}"#));
    assert!(found.contains("bright"));
}

#[test]
fn bad_points_and_structure_are_refused() {
    let (place, expected, _) = err(&one(r#"{"a": [0, 0, 0], "b": [1, 0]}"#));
    assert_eq!(place, "object \"room\", segment 0, \"a\"");
    assert!(expected.contains("[x, y]"));
    let (place, _, found) = err(&one(r#"{"a": [0, 0]}"#));
    assert!(place.ends_with("\"b\""));
    assert_eq!(found, "nothing");
    let (place, _, _) = err(r#"{"objects": []}"#);
    assert_eq!(place, "top level");
    let (_, expected, found) = err(r#"{"rhier_flatland": 2, "objects": []}"#);
    assert_eq!((expected.as_str(), found.as_str()), ("version 1", "2"));
    let (_, expected, _) = err(r#"{"rhier_flatland": 1, "objects": []}"#);
    assert!(expected.contains("at least one object"));
    let (_, _, found) = err(r#"{"rhier_flatland": 1, "objects": [{"name": "x", "segments": []}]}"#);
    assert_eq!(found, "[]");
    let (place, expected, _) = err("{\"rhier_flatland\": 1,\n \"objects\": [");
    assert!(place.starts_with("line 2"));
    assert_eq!(expected, "JSON");
    let (_, expected, _) = err("[1, 2]");
    assert_eq!(expected, "a JSON object");
}

#[test]
fn motion_keys_must_increase_in_time() {
    let text = format!(
        r#"{{"rhier_flatland": 1, "objects": [{{"name": "room", "segments": [{SEG_OK}],
        "motion": [{{"t": 1}}, {{"t": 1}}]}}]}}"#
    );
    let (place, expected, found) = err(&text);
    assert_eq!(place, "object \"room\", motion key 1, \"t\"");
    assert!(expected.contains("greater than"));
    assert_eq!(found, "1");
    let text = format!(
        r#"{{"rhier_flatland": 1, "objects": [{{"name": "room", "segments": [{SEG_OK}],
        "motion": [{{"translation": [0, 0]}}]}}]}}"#
    );
    let (place, _, found) = err(&text);
    assert!(place.ends_with("\"t\""));
    assert_eq!(found, "nothing");
}
