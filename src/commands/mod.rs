//! The subcommands, one module each, and what they share: the data files
//! (`data`), the printed output (`output`), and a command's error with its
//! exit code ([`Failure`]).

pub mod adapt;
pub mod calibrate;
pub mod collect;
pub mod data;
pub mod demo;
pub mod eval;
pub mod output;
pub mod robot;
pub mod serial;
pub mod tradeoff;
pub mod train;

use std::fmt::Display;

use tactile_force::exit::{Classify, ExitClass};

/// An argument a command refuses.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadArgument(pub String);

/// An argument refused: refused input.
impl Classify for BadArgument {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// A command's error: what went wrong with its causes, and how the process
/// exits ([`tactile_force::exit`]). It is made only from errors that
/// classify themselves, so each keeps its own exit code.
#[derive(Debug)]
pub struct Failure {
    class: ExitClass,
    error: anyhow::Error,
}

impl Failure {
    /// A failure of the work, said in `message` (exit 1).
    pub fn failed(message: String) -> Self {
        Failure {
            class: ExitClass::Failure,
            error: anyhow::Error::msg(message),
        }
    }

    /// The process's exit code.
    pub fn exit_code(&self) -> u8 {
        self.class.code()
    }
}

impl<E: Classify + std::error::Error + Send + Sync + 'static> From<E> for Failure {
    fn from(e: E) -> Self {
        Failure {
            class: e.class(),
            error: anyhow::Error::new(e),
        }
    }
}

/// The message and every cause, on one line, each said once: a cause
/// whose text the messages above it already hold (an error that prints
/// its source, as `"model file {path}: {source}"`) is not repeated.
impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut said = String::new();
        for cause in self.error.chain() {
            let text = cause.to_string();
            if said.contains(&text) {
                continue;
            }
            if !said.is_empty() {
                said.push_str(": ");
            }
            said.push_str(&text);
        }
        f.write_str(&said)
    }
}

/// A command's result.
pub type Result<T> = std::result::Result<T, Failure>;

/// What the command was doing when an error happened, said before the
/// error; the error's exit code is kept.
pub trait Context<T> {
    /// The error, after `context`.
    fn context<C: Display + Send + Sync + 'static>(self, context: C) -> Result<T>;
    /// The error, after the context `f` gives.
    fn with_context<C: Display + Send + Sync + 'static>(self, f: impl FnOnce() -> C) -> Result<T>;
}

impl<T, E: Into<Failure>> Context<T> for std::result::Result<T, E> {
    fn context<C: Display + Send + Sync + 'static>(self, context: C) -> Result<T> {
        self.with_context(|| context)
    }

    fn with_context<C: Display + Send + Sync + 'static>(self, f: impl FnOnce() -> C) -> Result<T> {
        self.map_err(|e| {
            let Failure { class, error } = e.into();
            Failure {
                class,
                error: error.context(f()),
            }
        })
    }
}
