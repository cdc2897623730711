//! What the README promises a newcomer before the first build: how long it takes, and that the
//! long quiet steps say what they are doing (issue 46, item 19).

use std::path::Path;

fn repo_file(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The paragraph of the README that starts with `start`.
fn paragraph<'a>(text: &'a str, start: &str) -> &'a str {
    let at = text
        .find(start)
        .unwrap_or_else(|| panic!("the README has no {start:?}"));
    text[at..].split("\n\n").next().unwrap()
}

#[test]
fn the_readme_says_how_long_the_first_build_and_the_python_install_take() {
    let readme = repo_file("README.md");
    let how_long = paragraph(&readme, "**How long.**");
    for promise in ["first", "build", "minutes", "pip install ./python"] {
        assert!(how_long.contains(promise), "{promise:?} not in: {how_long}");
    }
    let minutes: Vec<f64> = how_long
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter_map(|word| word.parse().ok())
        .collect();
    assert!(minutes.len() >= 2, "no durations in: {how_long}");
}

#[test]
fn the_python_build_says_what_it_builds_and_how_long_it_took() {
    let script = repo_file("scripts/test-python");
    let said: Vec<&str> = script
        .lines()
        .filter(|l| l.trim_start().starts_with("echo") && l.contains(">&2"))
        .collect();
    assert!(
        said.iter().any(|l| l.contains("building")) && said.iter().any(|l| l.contains("SECONDS")),
        "{said:?}"
    );
}

/// Every `--test NAME` the docs cite names a test binary that exists: the figures' commands
/// must run as written (`scripts/docs-figures` re-runs them).
#[test]
fn every_test_binary_the_docs_cite_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut binaries = Vec::new();
    for krate in std::fs::read_dir(root.join("crates")).unwrap() {
        let Ok(tests) = std::fs::read_dir(krate.unwrap().path().join("tests")) else {
            continue;
        };
        for entry in tests {
            let path = entry.unwrap().path();
            let stem = path.file_stem().unwrap().to_string_lossy().to_string();
            if path.extension().is_some_and(|e| e == "rs") || path.join("main.rs").exists() {
                binaries.push(stem);
            }
        }
    }
    let mut docs = vec![root.join("README.md"), root.join("CONTRIBUTING.md")];
    for doc in std::fs::read_dir(root.join("docs")).unwrap() {
        docs.push(doc.unwrap().path());
    }
    for doc in docs
        .iter()
        .filter(|d| d.extension().is_some_and(|e| e == "md"))
    {
        let text = std::fs::read_to_string(doc).unwrap().replace('\n', " ");
        for cited in text.split("--test ").skip(1) {
            let name: String = cited
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            assert!(
                binaries.contains(&name),
                "{}: --test {name} is no test binary ({binaries:?})",
                doc.display()
            );
        }
    }
}
