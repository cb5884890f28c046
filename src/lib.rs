//! vergence
