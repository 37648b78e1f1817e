//! The script language: its syntax tree and the parser that builds it.

mod ast;
mod duration;
mod lexer;
mod parser;

pub use ast::{Action, EnvVar, Script, State};
pub use parser::{KEYWORDS, MAX_INCLUDE_DEPTH, parse};
