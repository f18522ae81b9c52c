//! Built-in ops, one family per file. Each file documents shapes and the derivative, adds
//! `Tape` methods for its ops (`tape.conv2d(..)`), and checks its gradients beside the code.
//!
//! Registry rule: every op file declares `pub const OPS: &[&str]`, the names its ops return from
//! [`Op::name`](crate::Op::name), and its `#[cfg(test)]` module holds a gradient check (through
//! [`crate::check`]) for each of them. The registry test below fails when a name returned by
//! any `fn name` in an op file is missing from that file's `OPS`, and `tests` in each file fail
//! when a check fails.

pub mod broadcast;
pub mod channel;
pub mod conv;
pub mod elementwise;
pub mod fourier;
pub mod grid_sample;
pub mod loss;
pub mod matmul;
pub mod pool;
pub mod reduce;

/// The registry test. It reads the op sources at test time (every file under `src/ops`, so a
/// new file is covered without editing this list) and, per family (`conv.rs` plus `conv/…`):
/// 1. collects every name an op returns from `fn name(&self) -> &'static str` — string literals
///    in the body; for `self.helper()` bodies, the literals of `fn helper`; for a macro
///    metavariable (`$name`), the first string literal of each invocation of that macro —
///    and fails when one is missing from the family's `OPS`;
/// 2. fails when an `OPS` entry does not appear (as a whole word) in the family's test code, or
///    when that test code calls none of `check_gradients`, `check_inputs`, `check_surrogate`.
///
/// Test code is everything after the first `#[cfg(test)]` of a file, and whole files named
/// `tests.rs`.
#[cfg(test)]
mod registry {
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};

    /// `OPS` of each family; a family file without an entry here fails the test.
    fn ops_of(family: &str) -> Option<&'static [&'static str]> {
        Some(match family {
            "broadcast" => super::broadcast::OPS,
            "channel" => super::channel::OPS,
            "conv" => super::conv::OPS,
            "elementwise" => super::elementwise::OPS,
            "fourier" => super::fourier::OPS,
            "grid_sample" => super::grid_sample::OPS,
            "loss" => super::loss::OPS,
            "matmul" => super::matmul::OPS,
            "pool" => super::pool::OPS,
            "reduce" => super::reduce::OPS,
            "coupling" => crate::nn::coupling::OPS,
            _ => return None,
        })
    }

    /// Source with `//` comments blanked (string contents kept), so doc text is never read as code.
    fn strip_comments(src: &str) -> String {
        let b = src.as_bytes();
        let mut out = String::with_capacity(src.len());
        let (mut i, mut in_str) = (0, false);
        while i < b.len() {
            let c = b[i];
            if in_str {
                if c == b'\\' && i + 1 < b.len() {
                    out.push_str(&src[i..i + 2]);
                    i += 2;
                    continue;
                }
                in_str = c != b'"';
            } else if c == b'"' {
                in_str = true;
            } else if c == b'/' && b.get(i + 1) == Some(&b'/') {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
                continue;
            }
            let ch = src[i..].chars().next().unwrap();
            out.push(ch);
            i += ch.len_utf8();
        }
        out
    }

    /// String literals in `s`.
    fn literals(s: &str) -> Vec<String> {
        let mut out = Vec::new();
        let mut it = s.split('"');
        it.next();
        while let Some(lit) = it.next() {
            out.push(lit.to_string());
            it.next();
        }
        out
    }

    /// The text between the bracket at `open` and its match (string-aware).
    fn balanced(s: &str, open: usize) -> &str {
        let (o, c) = match s.as_bytes()[open] {
            b'(' => (b'(', b')'),
            b'[' => (b'[', b']'),
            _ => (b'{', b'}'),
        };
        let (mut depth, mut in_str) = (0usize, false);
        for (i, &ch) in s.as_bytes().iter().enumerate().skip(open) {
            if in_str {
                in_str = ch != b'"' || s.as_bytes()[i - 1] == b'\\';
            } else if ch == b'"' {
                in_str = true;
            } else if ch == o {
                depth += 1;
            } else if ch == c {
                depth -= 1;
                if depth == 0 {
                    return &s[open + 1..i];
                }
            }
        }
        panic!("registry: unbalanced bracket")
    }

    fn fn_body<'a>(code: &'a str, sig: &str) -> Vec<&'a str> {
        code.match_indices(sig)
            .map(|(at, _)| balanced(code, at + code[at..].find('{').expect("fn body")))
            .collect()
    }

    /// Names returned by the `fn name` methods of one family's library code.
    fn op_names(file: &Path, code: &str) -> Vec<String> {
        let mut names = Vec::new();
        for (at, _) in code.match_indices("fn name(&self) -> &'static str") {
            let body = balanced(code, at + code[at..].find('{').unwrap());
            let lits = literals(body);
            let t = body.trim();
            if !lits.is_empty() {
                names.extend(lits);
            } else if let Some(helper) = t.strip_prefix("self.").and_then(|r| r.strip_suffix("()"))
            {
                let found: Vec<String> = fn_body(code, &format!("fn {helper}("))
                    .into_iter()
                    .flat_map(literals)
                    .collect();
                assert!(
                    !found.is_empty(),
                    "{}: fn {helper} returns no string literal",
                    file.display()
                );
                names.extend(found);
            } else if t.starts_with('$') {
                let mac_at = code[..at]
                    .rfind("macro_rules!")
                    .expect("metavariable outside a macro");
                let mac = code[mac_at + 12..]
                    .split_whitespace()
                    .next()
                    .unwrap()
                    .to_string();
                let call = format!("{mac}!");
                let mut n = 0;
                for (c, _) in code.match_indices(&call) {
                    let open = c + code[c..].find(['(', '[', '{']).unwrap();
                    let args = balanced(code, open);
                    names.extend(literals(args).into_iter().take(1));
                    n += 1;
                }
                assert!(
                    n > 0,
                    "{}: macro {mac} defines an op name but is never invoked",
                    file.display()
                );
            } else {
                panic!(
                    "{}: cannot read an op name from `fn name` body {t:?}; return a literal",
                    file.display()
                );
            }
        }
        names
    }

    fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                sources(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }

    #[test]
    fn every_op_is_registered_and_checked() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/ops");
        let mut files = Vec::new();
        sources(&root, &mut files);
        // family → (library code, test code)
        let mut fam: BTreeMap<String, (String, String)> = BTreeMap::new();
        for f in &files {
            let rel = f.strip_prefix(&root).unwrap();
            let family = rel
                .components()
                .next()
                .unwrap()
                .as_os_str()
                .to_string_lossy()
                .trim_end_matches(".rs")
                .to_string();
            let src = strip_comments(&std::fs::read_to_string(f).unwrap());
            let entry = fam.entry(family).or_default();
            if f.file_stem().is_some_and(|s| s == "tests") {
                entry.1.push_str(&src);
            } else {
                let (lib, test) = src.split_at(src.find("#[cfg(test)]").unwrap_or(src.len()));
                entry.0.push_str(lib);
                entry.1.push_str(test);
            }
        }
        // Ops defined beside their network blocks (src/nn) follow the same rule; files there
        // that define no op are skipped.
        let nn = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/nn");
        let mut nn_files = Vec::new();
        sources(&nn, &mut nn_files);
        for f in &nn_files {
            let src = strip_comments(&std::fs::read_to_string(f).unwrap());
            let (lib, test) = src.split_at(src.find("#[cfg(test)]").unwrap_or(src.len()));
            if lib.contains("fn name(&self) -> &'static str") {
                let family = f.file_stem().unwrap().to_string_lossy().to_string();
                let entry = fam.entry(family).or_default();
                entry.0.push_str(lib);
                entry.1.push_str(test);
            }
        }
        let mut problems = Vec::new();
        for (family, (lib, test)) in &fam {
            let Some(ops) = ops_of(family) else {
                problems.push(format!(
                    "ops/{family}: not listed in the registry test (ops.rs)"
                ));
                continue;
            };
            for name in op_names(&root.join(family), lib) {
                if !ops.contains(&name.as_str()) {
                    problems.push(format!("ops/{family}: op {name:?} is missing from OPS"));
                }
            }
            let checks = ["check_gradients", "check_inputs", "check_surrogate"];
            if !ops.is_empty() && !checks.iter().any(|c| test.contains(c)) {
                problems.push(format!("ops/{family}: tests call no gradient check"));
            }
            for name in ops.iter() {
                let word = |at: usize| {
                    let ok = |c: Option<char>| c.is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
                    ok(test[..at].chars().next_back()) && ok(test[at + name.len()..].chars().next())
                };
                if !test.match_indices(name).any(|(at, _)| word(at)) {
                    problems.push(format!(
                        "ops/{family}: OPS entry {name:?} has no gradient check in its tests"
                    ));
                }
            }
        }
        assert!(
            problems.is_empty(),
            "registry:\n  {}",
            problems.join("\n  ")
        );
        assert!(
            fam.len() >= 10,
            "registry: read only {} op families",
            fam.len()
        );
    }

    #[test]
    fn the_scanner_reads_literals_helpers_and_macros() {
        let code = strip_comments(
            r#"
            // fn name(&self) -> &'static str { "commented_out" }
            impl A { fn name(&self) -> &'static str { if x { "a1" } else { "a2" } } }
            impl B { fn name(&self) -> &'static str { self.op() } fn op(&self) -> &'static str { "b" } }
            macro_rules! m { ($n:ident, $s:literal) => { fn name(&self) -> &'static str { $s } } }
            m!(/// doc with no quotes
               C, "c");
            m!(D, "d");
            "#,
        );
        let names = op_names(Path::new("x"), &code);
        assert_eq!(names, ["a1", "a2", "b", "c", "d"]);
    }
}
