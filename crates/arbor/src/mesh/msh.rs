//! The Cornell `.msh` mesh format.
