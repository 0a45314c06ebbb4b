//! Errors of the design functions: what is wrong and what to do about it.

use std::fmt;

/// Why a design could not be made.
#[derive(Clone, Debug, PartialEq)]
pub enum DesignError {
    /// The request cannot be met as given (a target out of range, unsorted or duplicate
    /// frequencies, a decay time that cannot be met...): what is wrong and a hint.
    Invalid {
        /// What is wrong.
        message: String,
        /// What to change.
        hint: String,
    },
    /// A numerical method failed (lost positivity, no convergence): what happened.
    Numerical(String),
    /// A model given to the design could not be loaded or analysed: the rendered diagnostic.
    Model(String),
}

impl DesignError {
    /// An [`DesignError::Invalid`] from a message and a hint.
    pub fn invalid(message: impl Into<String>, hint: impl Into<String>) -> DesignError {
        DesignError::Invalid {
            message: message.into(),
            hint: hint.into(),
        }
    }
}

impl fmt::Display for DesignError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DesignError::Invalid { message, hint } => write!(f, "{message} (hint: {hint})"),
            DesignError::Numerical(m) => write!(f, "{m}"),
            DesignError::Model(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for DesignError {}
