//! End-to-end: hostile input files give one-line errors through the binary (issue 11).

use crate::common::tolles;
use tempfile::TempDir;

/// Runs `tolles fit FILE`, expects failure and returns stderr.
fn fit_fails(file: &std::path::Path) -> String {
    let out = tolles()
        .args([
            "fit",
            file.to_str().unwrap(),
            "--scalar",
            "mag",
            "--vector",
            "flux",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    String::from_utf8(out.stderr).unwrap()
}

#[test]
fn os_errors_are_printed_once() {
    let dir = TempDir::new().unwrap();
    let e = fit_fails(&dir.path().join("absent.csv"));
    assert_eq!(e.matches("os error").count(), 1, "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
}

#[test]
fn text_that_is_not_utf8_names_its_line() {
    let dir = TempDir::new().unwrap();
    let csv = dir.path().join("h.csv");
    std::fs::write(&csv, b"tt,m\xffag\n1,2\n").unwrap();
    let e = fit_fails(&csv);
    assert!(
        e.contains("h.csv: line 1: field 2 is not UTF-8 text"),
        "{e}"
    );
    assert!(!e.contains('{'), "{e}");

    let xyz = dir.path().join("f.xyz");
    std::fs::write(&xyz, b"/ tt mag\n0 1\n1 \xff\n").unwrap();
    let e = fit_fails(&xyz);
    assert!(e.contains("f.xyz: line 3: not UTF-8 text"), "{e}");

    std::fs::write(dir.path().join("g.dfn"), "DEFN 1 ST=RECD,RT=;TT:F10.1\n").unwrap();
    let dat = dir.path().join("g.dat");
    std::fs::write(&dat, b"0.0\n1.\xff\n").unwrap();
    let e = fit_fails(&dat);
    assert!(e.contains("g.dat: line 2: not UTF-8 text"), "{e}");
}

#[test]
fn huge_headers_fail_fast() {
    let dir = TempDir::new().unwrap();
    // 400 000 distinct names: the duplicate check was quadratic (two minutes).
    let names: Vec<String> = (0..400_000).map(|k| format!("c{k}")).collect();
    let wide = dir.path().join("wide.csv");
    std::fs::write(&wide, names.join(",") + "\n").unwrap();
    let start = std::time::Instant::now();
    let e = fit_fails(&wide);
    assert!(start.elapsed().as_secs() < 20, "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    // A header line beyond the limit is refused before its names are held in memory.
    let huge = dir.path().join("huge.csv");
    std::fs::write(&huge, "a,".repeat(1 << 20) + "a\n1\n").unwrap();
    let e = fit_fails(&huge);
    assert!(
        e.contains("huge.csv: line 1: the header line is longer than"),
        "{e}"
    );
}

#[test]
fn an_unterminated_quote_names_the_line_it_opens_on() {
    let dir = TempDir::new().unwrap();
    let csv = dir.path().join("q.csv");
    let text = "tt,mag,flux_x,flux_y,flux_z\n0,1,2,3,4\n0.1,\"5,2,3,4\n0.2,1,2,3,4\n0.3,1,2,3,4\n";
    std::fs::write(&csv, text).unwrap();
    let e = fit_fails(&csv);
    assert!(
        e.contains("q.csv: line 3: a quote opened on this line is never closed"),
        "{e}"
    );
}
