//! `tolles plan` through the binary.

use assert_cmd::Command;
use serde_json::Value;

fn plan(args: &[&str]) -> Value {
    let out = Command::cargo_bin("tolles")
        .unwrap()
        .arg("plan")
        .args(args)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn term<'a>(report: &'a Value, name: &str) -> &'a Value {
    report["identifiability"]["terms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["name"] == name)
        .unwrap()
}

fn carriers(t: &Value) -> Vec<String> {
    t["carried_by"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c[0].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn a_box_without_yaws_loses_the_yaw_information() {
    let full = plan(&["--plan", "box"]);
    let no_yaw = plan(&["--plan", "box", "--without", "yaw"]);
    let (a, b) = (term(&full, "lt"), term(&no_yaw, "lt"));
    assert!(carriers(a).iter().any(|c| c == "yaw on 090°"));
    assert!(carriers(b).iter().all(|c| !c.starts_with("yaw")));
    assert!(b["std_error"].as_f64().unwrap() > 1.05 * a["std_error"].as_f64().unwrap());
}

#[test]
fn wing_ups_are_suggested_for_perm_v_and_remove_the_collinearity() {
    let report = plan(&["--plan", "box"]);
    let v = term(&report, "V");
    assert_eq!(v["collinear"], true);
    let suggestions = report["suggestions"].as_array().unwrap();
    let for_v = suggestions.iter().find(|s| s[0] == "V").unwrap();
    assert!(
        for_v[1][0][0].as_str().unwrap().contains("wing-up"),
        "{for_v}"
    );
    let with_wingups = plan(&[
        "--maneuvers",
        "roll@0,roll@90,roll@180,roll@270,pitch@0,pitch@90,wingup@90,wingup@270",
    ]);
    let v2 = term(&with_wingups, "V");
    assert!(v2["vif"].as_f64().unwrap() < v["vif"].as_f64().unwrap() / 10.0);
}

#[test]
fn a_bad_maneuver_list_is_a_one_line_error() {
    let out = Command::cargo_bin("tolles")
        .unwrap()
        .args(["plan", "--maneuvers", "roll@0,loop@90"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.contains("unknown kind \"loop\"") && stderr.lines().count() == 1,
        "{stderr}"
    );
}

#[test]
fn a_flown_box_is_evaluated_from_its_detected_maneuvers() {
    let dir = tempfile::TempDir::new().unwrap();
    let fly = |name: &str, yaw: &str| {
        let path = dir.path().join(name);
        Command::cargo_bin("tolles")
            .unwrap()
            .args([
                "simulate",
                "--plan",
                "box",
                "--preset",
                "tail-stinger",
                "--yaw",
                yaw,
                "--out",
            ])
            .arg(&path)
            .assert()
            .success();
        plan(&[path.to_str().unwrap(), "--vector", "flux_a"])
    };
    let full = fly("box.csv", "5");
    let no_yaw = fly("noyaw.csv", "0");
    let lt = |r: &Value| term(r, "lt").clone();
    assert!(
        carriers(&lt(&full))
            .iter()
            .any(|c| c.starts_with("yaw on 090°")),
        "{:?}",
        carriers(&lt(&full))
    );
    assert!(carriers(&lt(&no_yaw)).iter().all(|c| !c.starts_with("yaw")));
    assert!(
        lt(&no_yaw)["std_error"].as_f64().unwrap()
            > 1.05 * lt(&full)["std_error"].as_f64().unwrap()
    );
}
