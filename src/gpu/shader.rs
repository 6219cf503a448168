//! The `//!include` directive for WGSL, resolved the same way at build time and at run time.
//!
//! A line whose first non-blank characters are `//!include <path>` is replaced by the text of the
//! file `shaders/<path>` (paths are always relative to `shaders/`, never to the including file,
//! and use `/`). Includes nest, and each file is included **at most once** per resolved shader:
//! a second directive for a file that is already in (including the root file itself) becomes a
//! comment line. So a snippet can include what it uses without caring who else includes it, and
//! include cycles are harmless.
//!
//! This file is compiled twice: as `diffsil::gpu::shader`, and inside `build.rs` through
//! `#[path = "src/gpu/shader.rs"]`, so that the build-time validation and the run-time loader
//! use one implementation. It must therefore depend on nothing but `std`.

use std::fmt;

/// The directive, at the start of a line (after optional blanks), followed by blanks and a path.
pub const INCLUDE_DIRECTIVE: &str = "//!include";

/// Where one line of a resolved shader came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LineOrigin {
    /// The file, relative to `shaders/` (or the name given to [`resolve_source`]).
    pub file: String,
    /// 1-based line number in that file.
    pub line: u32,
}

impl fmt::Display for LineOrigin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.file, self.line)
    }
}

/// A shader with its includes spliced in.
#[derive(Clone, Debug)]
pub struct ResolvedShader {
    /// The root file's name.
    pub name: String,
    /// The complete WGSL text, lines joined with `\n`.
    pub source: String,
    /// One entry per line of `source`: the file and line it was copied from.
    pub origins: Vec<LineOrigin>,
}

impl ResolvedShader {
    /// Where the 1-based `line` of [`ResolvedShader::source`] came from.
    pub fn origin(&self, line: u32) -> Option<&LineOrigin> {
        self.origins.get((line as usize).checked_sub(1)?)
    }

    /// Whether any include was spliced in (so line numbers differ from the root file's).
    pub fn has_includes(&self) -> bool {
        self.origins.iter().any(|o| o.file != self.name)
    }
}

/// Why a shader could not be resolved.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum IncludeError {
    /// The shader asked for is not one of the embedded files.
    UnknownShader {
        /// The name asked for.
        name: String,
        /// The names that exist.
        known: Vec<String>,
    },
    /// An `//!include` names a file that does not exist under `shaders/`.
    MissingInclude {
        /// The directive's location.
        at: LineOrigin,
        /// The path it names.
        target: String,
    },
    /// An `//!include` without a path, or with something after it.
    Malformed {
        /// The directive's location.
        at: LineOrigin,
        /// The line as written.
        text: String,
    },
}

impl fmt::Display for IncludeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IncludeError::UnknownShader { name, known } => {
                write!(f, "no shader named `{name}`; the embedded shaders are: {}", known.join(", "))
            }
            IncludeError::MissingInclude { at, target } => write!(
                f,
                "{at}: `{INCLUDE_DIRECTIVE} {target}` names a file that does not exist \
                 (include paths are relative to `shaders/`, e.g. `{INCLUDE_DIRECTIVE} shared/dispatch.wgsl`)"
            ),
            IncludeError::Malformed { at, text } => write!(
                f,
                "{at}: malformed include directive `{text}`; write exactly `{INCLUDE_DIRECTIVE} <path relative to shaders/>`"
            ),
        }
    }
}

impl std::error::Error for IncludeError {}

/// Resolves the embedded shader `name` (a path relative to `shaders/`, e.g. `smoke.wgsl`) over
/// `files`, a map of every file under `shaders/` as `(relative path, text)`.
pub fn resolve(files: &[(&str, &str)], name: &str) -> Result<ResolvedShader, IncludeError> {
    match lookup(files, name) {
        Some(text) => resolve_source(files, name, text),
        None => Err(IncludeError::UnknownShader {
            name: name.to_owned(),
            known: files.iter().map(|(n, _)| (*n).to_owned()).collect(),
        }),
    }
}

/// Resolves the includes of `source` (which need not be one of `files`; `name` is only used in
/// messages and origins, and counts as already included) over `files`.
pub fn resolve_source(files: &[(&str, &str)], name: &str, source: &str) -> Result<ResolvedShader, IncludeError> {
    let mut out =
        ResolvedShader { name: name.to_owned(), source: String::with_capacity(source.len()), origins: Vec::new() };
    let mut included = vec![name.to_owned()];
    splice(files, name, source, &mut included, &mut out)?;
    Ok(out)
}

fn lookup<'a>(files: &[(&str, &'a str)], name: &str) -> Option<&'a str> {
    files.iter().find(|(n, _)| *n == name).map(|(_, text)| *text)
}

fn push_line(out: &mut ResolvedShader, text: &str, file: &str, line: u32) {
    if !out.origins.is_empty() {
        out.source.push('\n');
    }
    out.source.push_str(text);
    out.origins.push(LineOrigin { file: file.to_owned(), line });
}

fn splice(
    files: &[(&str, &str)],
    name: &str,
    source: &str,
    included: &mut Vec<String>,
    out: &mut ResolvedShader,
) -> Result<(), IncludeError> {
    for (index, text) in source.lines().enumerate() {
        let line = u32::try_from(index + 1).unwrap_or(u32::MAX);
        let Some(rest) = text.trim_start().strip_prefix(INCLUDE_DIRECTIVE) else {
            push_line(out, text, name, line);
            continue;
        };
        let at = || LineOrigin { file: name.to_owned(), line };
        // `//!included` and the like are not directives.
        if !rest.is_empty() && !rest.starts_with(char::is_whitespace) {
            push_line(out, text, name, line);
            continue;
        }
        let mut words = rest.split_whitespace();
        let (Some(target), None) = (words.next(), words.next()) else {
            return Err(IncludeError::Malformed { at: at(), text: text.trim().to_owned() });
        };
        if included.iter().any(|done| done == target) {
            push_line(out, &format!("// {INCLUDE_DIRECTIVE} {target}: already included"), name, line);
            continue;
        }
        let Some(body) = lookup(files, target) else {
            return Err(IncludeError::MissingInclude { at: at(), target: target.to_owned() });
        };
        included.push(target.to_owned());
        splice(files, target, body, included, out)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILES: &[(&str, &str)] = &[
        ("main.wgsl", "//!include shared/a.wgsl\n  //!include shared/b.wgsl\nfn main() {}"),
        ("shared/a.wgsl", "fn a() {}"),
        ("shared/b.wgsl", "//!include shared/a.wgsl\nfn b() { a(); }"),
        ("cycle.wgsl", "//!include shared/c.wgsl\nfn x() {}"),
        ("shared/c.wgsl", "//!include cycle.wgsl\nfn c() {}"),
    ];

    #[test]
    fn includes_once_and_tracks_origins() {
        let r = resolve(FILES, "main.wgsl").unwrap();
        assert_eq!(r.source, "fn a() {}\n// //!include shared/a.wgsl: already included\nfn b() { a(); }\nfn main() {}");
        assert_eq!(r.origins.len(), 4);
        assert_eq!(r.origin(1).unwrap().to_string(), "shared/a.wgsl:1");
        assert_eq!(r.origin(2).unwrap().to_string(), "shared/b.wgsl:1");
        assert_eq!(r.origin(3).unwrap().to_string(), "shared/b.wgsl:2");
        assert_eq!(r.origin(4).unwrap().to_string(), "main.wgsl:3");
        assert!(r.origin(0).is_none() && r.origin(5).is_none());
        assert!(r.has_includes());
    }

    #[test]
    fn cycles_terminate() {
        let r = resolve(FILES, "cycle.wgsl").unwrap();
        assert!(r.source.ends_with("fn c() {}\nfn x() {}"), "{}", r.source);
    }

    #[test]
    fn errors_are_values() {
        assert!(matches!(resolve(FILES, "nope.wgsl"), Err(IncludeError::UnknownShader { .. })));
        let e = resolve_source(FILES, "inline", "fn f() {}\n//!include shared/zz.wgsl").unwrap_err();
        assert_eq!(
            e,
            IncludeError::MissingInclude {
                at: LineOrigin { file: "inline".into(), line: 2 },
                target: "shared/zz.wgsl".into()
            }
        );
        assert!(e.to_string().starts_with("inline:2: "));
        assert!(matches!(resolve_source(FILES, "x", "//!include"), Err(IncludeError::Malformed { .. })));
        assert!(matches!(resolve_source(FILES, "x", "//!include a b"), Err(IncludeError::Malformed { .. })));
        // Not a directive: passed through.
        assert_eq!(resolve_source(FILES, "x", "//!included\n").unwrap().source, "//!included");
    }
}
