//! The hand-written, line-oriented parser: one line is one item, indentation is free.
//!
//! Settings that may be global or per state (`restart`, `env`) belong to the state whose
//! `state` line comes last before them in the same file; before the first `state` line of a
//! file (and after an `include` line) they are global. After a line with an error the
//! parser goes on with the next line, so one run reports every broken line; the lines that
//! belong to a broken `state` line are skipped rather than reported again.

use std::path::{Path, PathBuf};

use super::ast::{Action, EnvVar, Script, State};
use super::duration::parse_timeout_ns;
use super::lexer::{Token, tokenize};
use crate::diagnostic::{Diagnostic, Diagnostics, Problem, diagnostic};
use crate::location::{Location, Spanned};
use crate::source::SourceLoader;
use lewis_stdx::closest;

/// How deep includes may nest.
pub const MAX_INCLUDE_DEPTH: usize = 32;

/// Every keyword a line may start with (the guide's script chapter names each; a test checks).
pub const KEYWORDS: [&str; 9] = [
    "start", "restart", "recovery", "use", "state", "action", "timeout", "env", "include",
];

/// Parses the script at `root` and the files it includes, read through `loader`.
///
/// # Errors
/// Every syntax error of every file, in source order.
pub fn parse(root: &Path, loader: &dyn SourceLoader) -> Result<Script, Diagnostics> {
    let mut parser = Parser {
        loader,
        script: Script::new(root),
        errors: Vec::new(),
        chain: Vec::new(),
    };
    parser.file(root, None);
    if parser.errors.is_empty() {
        Ok(parser.script)
    } else {
        Err(Diagnostics::new(parser.errors))
    }
}

/// What the lines read so far in a file belong to.
#[derive(Debug, Clone, Copy)]
enum Block {
    /// The script as a whole.
    Global,
    /// The state at this index.
    State(usize),
    /// A `state` line with an error: its lines are skipped.
    BrokenState,
}

struct Parser<'a> {
    loader: &'a dyn SourceLoader,
    script: Script,
    errors: Vec<Diagnostic>,
    /// The files being read, outermost first: (identity, path as reached).
    chain: Vec<(PathBuf, PathBuf)>,
}

/// One line being read: its tokens and where they are.
struct Line<'t> {
    file: &'t Path,
    number: u32,
    keyword: &'static str,
    usage: &'static str,
    tokens: &'t [Token],
    next: usize,
}

type LineResult<T> = Result<T, Diagnostic>;

impl<'t> Line<'t> {
    fn at(&self, column: u32) -> Location {
        Location::new(self.file, self.number, column)
    }

    fn error(&self, column: u32, problem: Problem) -> Diagnostic {
        diagnostic(self.at(column), problem)
    }

    /// The next token, or an error saying that `what` is missing.
    fn expect(&mut self, what: &'static str) -> LineResult<&Token> {
        match self.tokens.get(self.next) {
            Some(token) => {
                self.next += 1;
                Ok(token)
            }
            None => Err(self.missing(what)),
        }
    }

    /// The error for a line that ends before `what`, placed just after its last word.
    fn missing(&self, what: &'static str) -> Diagnostic {
        let column = self.tokens.last().map_or(1, |t| t.end_column);
        self.error(
            column,
            Problem::MissingArgument {
                keyword: self.keyword,
                what,
                usage: self.usage,
            },
        )
    }

    /// The tokens not read yet.
    fn rest(&mut self) -> &'t [Token] {
        let tokens: &'t [Token] = self.tokens;
        let rest = tokens.get(self.next..).unwrap_or(&[]);
        self.next = self.tokens.len();
        rest
    }

    /// An error when tokens are left over.
    fn finish(&self) -> LineResult<()> {
        match self.tokens.get(self.next) {
            None => Ok(()),
            Some(extra) => Err(self.error(
                extra.column,
                Problem::UnexpectedArgument {
                    keyword: self.keyword,
                    found: extra.text.clone(),
                    usage: self.usage,
                },
            )),
        }
    }

    /// The next token as a fixed word of the syntax.
    fn word(&mut self, expected: &'static str) -> LineResult<()> {
        let token = self.expect(expected)?;
        if token.text == expected && !token.quoted {
            return Ok(());
        }
        let (column, found) = (token.column, token.text.clone());
        Err(self.error(
            column,
            Problem::ExpectedWord {
                expected,
                found,
                usage: self.usage,
            },
        ))
    }

    /// The next token as a state name; `stop` is returned as is.
    fn state_name(&mut self) -> LineResult<Spanned<String>> {
        let token = self.expect("a state name")?;
        let (column, text) = (token.column, token.text.clone());
        if is_identifier(&text, true) {
            Ok(Spanned::new(text, self.at(column)))
        } else {
            Err(self.error(column, Problem::InvalidStateName { found: text }))
        }
    }

    /// The next token as a string passed to a program.
    fn program_string(&mut self, what: &'static str) -> LineResult<Spanned<String>> {
        let token = self.expect(what)?;
        let (column, text) = (token.column, token.text.clone());
        let spanned = Spanned::new(text, self.at(column));
        check_no_nul(&spanned, what)?;
        Ok(spanned)
    }
}

fn check_no_nul(text: &Spanned<String>, what: &'static str) -> LineResult<()> {
    if text.value.contains('\0') {
        Err(diagnostic(
            text.location.clone(),
            Problem::NulCharacter { what },
        ))
    } else {
        Ok(())
    }
}

/// Whether `text` is a name: a letter or `_`, then letters, digits, `_` (and `-` when
/// `dash` is allowed).
fn is_identifier(text: &str, dash: bool) -> bool {
    let mut chars = text.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || (dash && c == '-'))
}

fn usage(keyword: &str) -> &'static str {
    match keyword {
        "start" => "start STATE",
        "restart" => "restart N",
        "recovery" => "recovery STATE",
        "use" => "use gui",
        "state" => "state NAME PROGRAM [ARGS...]",
        "action" => "action CODE trans STATE",
        "timeout" => "timeout DURATION",
        "env" => "env KEY=VALUE...",
        "include" => "include \"FILE\"",
        _ => "",
    }
}

impl Parser<'_> {
    fn file(&mut self, path: &Path, included_at: Option<&Location>) {
        let at = || {
            included_at
                .cloned()
                .unwrap_or_else(|| Location::whole_file(path))
        };
        if self.chain.len() >= MAX_INCLUDE_DEPTH {
            self.errors.push(diagnostic(
                at(),
                Problem::IncludeTooDeep {
                    limit: MAX_INCLUDE_DEPTH,
                },
            ));
            return;
        }
        let source = match self.loader.load(path) {
            Ok(source) => source,
            Err(error) => {
                self.errors.push(diagnostic(
                    at(),
                    Problem::Unreadable {
                        path: path.to_owned(),
                        error: error.to_string(),
                    },
                ));
                return;
            }
        };
        if let Some(first) = self.chain.iter().position(|(id, _)| *id == source.identity) {
            let mut chain: Vec<PathBuf> =
                self.chain[first..].iter().map(|(_, p)| p.clone()).collect();
            chain.push(path.to_owned());
            self.errors
                .push(diagnostic(at(), Problem::IncludeCycle { chain }));
            return;
        }
        self.chain.push((source.identity, path.to_owned()));
        let text = source.text.strip_prefix('\u{feff}').unwrap_or(&source.text);
        let mut block = Block::Global;
        for (index, line) in text.lines().enumerate() {
            let number = u32::try_from(index + 1).unwrap_or(u32::MAX);
            if let Err(error) = self.line(path, number, line, &mut block) {
                self.errors.push(error);
            }
        }
        self.chain.pop();
    }

    fn line(&mut self, file: &Path, number: u32, text: &str, block: &mut Block) -> LineResult<()> {
        let tokens = match tokenize(text) {
            Ok(tokens) => tokens,
            Err(error) => {
                if text.split_whitespace().next() == Some("state") {
                    *block = Block::BrokenState;
                }
                return Err(diagnostic(
                    Location::new(file, number, error.column),
                    error.problem,
                ));
            }
        };
        let Some(first) = tokens.first() else {
            return Ok(());
        };
        let location = Location::new(file, number, first.column);
        if first.quoted {
            return Err(diagnostic(location, Problem::QuotedKeyword));
        }
        let Some(&keyword) = KEYWORDS.iter().find(|k| **k == first.text) else {
            let suggestion = closest(&first.text, KEYWORDS);
            let found = first.text.clone();
            return Err(diagnostic(
                location,
                Problem::UnknownKeyword { found, suggestion },
            ));
        };
        let mut line = Line {
            file,
            number,
            keyword,
            usage: usage(keyword),
            tokens: &tokens,
            next: 1,
        };
        match keyword {
            "start" => self.start(&mut line, location),
            "restart" => self.restart(&mut line, location, *block),
            "recovery" => self.recovery(&mut line, location),
            "use" => self.use_feature(&mut line, location),
            "state" => {
                // Until the line is known to be good, its lines are skipped.
                *block = Block::BrokenState;
                self.state(&mut line)?;
                *block = Block::State(self.script.states.len() - 1);
                Ok(())
            }
            "action" => match *block {
                Block::State(index) => self.action(&mut line, location, index),
                Block::BrokenState => Ok(()),
                Block::Global => {
                    Err(line.error(location.column, Problem::OutsideState { keyword }))
                }
            },
            "timeout" => match *block {
                Block::State(index) => self.timeout(&mut line, location, index),
                Block::BrokenState => Ok(()),
                Block::Global => {
                    Err(line.error(location.column, Problem::OutsideState { keyword }))
                }
            },
            "env" => self.env(&mut line, *block),
            _ => {
                let include = line.program_string("a file")?;
                line.finish()?;
                let path = include.location.folder().join(&include.value);
                self.file(&path, Some(&location));
                *block = Block::Global;
                Ok(())
            }
        }
    }

    fn start(&mut self, line: &mut Line<'_>, location: Location) -> LineResult<()> {
        let name = line.state_name()?;
        line.finish()?;
        if name.value == "stop" {
            return Err(diagnostic(
                name.location,
                Problem::StopNotAllowed { keyword: "start" },
            ));
        }
        set_once(&mut self.script.start, name, "start", location)
    }

    fn recovery(&mut self, line: &mut Line<'_>, location: Location) -> LineResult<()> {
        let name = line.state_name()?;
        line.finish()?;
        if name.value == "stop" {
            return Err(diagnostic(
                name.location,
                Problem::StopNotAllowed {
                    keyword: "recovery",
                },
            ));
        }
        set_once(&mut self.script.recovery, name, "recovery", location)
    }

    fn use_feature(&mut self, line: &mut Line<'_>, location: Location) -> LineResult<()> {
        let feature = line.expect("a feature")?;
        if feature.text != "gui" || feature.quoted {
            let (column, found) = (feature.column, feature.text.clone());
            return Err(line.error(column, Problem::UnknownFeature { found }));
        }
        line.finish()?;
        match &self.script.use_gui {
            Some(first) => Err(diagnostic(
                location,
                Problem::DuplicateSetting {
                    what: "use gui".into(),
                    first: first.clone(),
                },
            )),
            None => {
                self.script.use_gui = Some(location);
                Ok(())
            }
        }
    }

    fn restart(&mut self, line: &mut Line<'_>, location: Location, block: Block) -> LineResult<()> {
        let token = line.expect("a number of restarts")?;
        let (column, text) = (token.column, token.text.clone());
        let limit = match text.parse::<u32>() {
            Ok(limit) if text.bytes().all(|b| b.is_ascii_digit()) => limit,
            _ => return Err(line.error(column, Problem::InvalidRestartLimit { found: text })),
        };
        line.finish()?;
        let limit = Spanned::new(limit, location.clone());
        match block {
            Block::Global => set_once(&mut self.script.restart, limit, "restart", location),
            Block::State(index) => set_once(
                &mut self.script.states[index].restart,
                limit,
                "restart",
                location,
            ),
            Block::BrokenState => Ok(()),
        }
    }

    fn state(&mut self, line: &mut Line<'_>) -> LineResult<()> {
        let name = line.state_name()?;
        if name.value == "stop" {
            return Err(diagnostic(name.location, Problem::StopDefined));
        }
        let program = line.program_string("a program")?;
        if program.value.is_empty() {
            return Err(diagnostic(program.location, Problem::EmptyProgram));
        }
        let mut args = Vec::new();
        for token in line.rest() {
            let arg = Spanned::new(
                token.text.clone(),
                Location::new(line.file, line.number, token.column),
            );
            check_no_nul(&arg, "argument")?;
            args.push(arg);
        }
        self.script.states.push(State {
            name,
            program,
            args,
            actions: Vec::new(),
            timeout_ns: None,
            restart: None,
            env: Vec::new(),
        });
        Ok(())
    }

    fn action(&mut self, line: &mut Line<'_>, location: Location, state: usize) -> LineResult<()> {
        let token = line.expect("an exit code")?;
        let (column, text) = (token.column, token.text.clone());
        let code = match text.parse::<i32>() {
            Ok(code) if (0..=255).contains(&code) && text.bytes().all(|b| b.is_ascii_digit()) => {
                code
            }
            _ => return Err(line.error(column, Problem::InvalidExitCode { found: text })),
        };
        line.word("trans")?;
        let target = line.state_name()?;
        line.finish()?;
        self.script.states[state].actions.push(Action {
            location,
            code: Spanned::new(code, Location::new(line.file, line.number, column)),
            target,
        });
        Ok(())
    }

    fn timeout(&mut self, line: &mut Line<'_>, location: Location, state: usize) -> LineResult<()> {
        let token = line.expect("a duration")?;
        let column = token.column;
        let timeout_ns =
            parse_timeout_ns(&token.text).map_err(|problem| line.error(column, problem))?;
        line.finish()?;
        let timeout_ns = Spanned::new(timeout_ns, location.clone());
        set_once(
            &mut self.script.states[state].timeout_ns,
            timeout_ns,
            "timeout",
            location,
        )
    }

    fn env(&mut self, line: &mut Line<'_>, block: Block) -> LineResult<()> {
        let tokens = line.rest();
        if tokens.is_empty() {
            return Err(line.missing("a variable"));
        }
        let mut vars = Vec::new();
        for token in tokens {
            let invalid = |reason| {
                diagnostic(
                    Location::new(line.file, line.number, token.column),
                    Problem::InvalidEnv {
                        found: token.text.clone(),
                        reason,
                    },
                )
            };
            let Some((key, value)) = token.text.split_once('=') else {
                return Err(invalid("it has no `=`"));
            };
            if !is_identifier(key, false) {
                return Err(invalid(
                    "the name must be letters, digits and `_`, not starting with a digit",
                ));
            }
            if value.contains('\0') {
                return Err(invalid("the value contains a NUL character"));
            }
            vars.push(EnvVar {
                key: Spanned::new(
                    key.to_owned(),
                    Location::new(line.file, line.number, token.column),
                ),
                value: value.to_owned(),
            });
        }
        match block {
            Block::Global => self.script.env.extend(vars),
            Block::State(index) => self.script.states[index].env.extend(vars),
            Block::BrokenState => {}
        }
        Ok(())
    }
}

/// Sets a setting given once per scope, or says where it was first given.
fn set_once<T>(
    slot: &mut Option<Spanned<T>>,
    value: Spanned<T>,
    what: &str,
    location: Location,
) -> LineResult<()> {
    match slot {
        Some(first) => Err(diagnostic(
            location,
            Problem::DuplicateSetting {
                what: what.to_owned(),
                first: first.location.clone(),
            },
        )),
        None => {
            *slot = Some(value);
            Ok(())
        }
    }
}
