//! Rock identifiers, shared by the catalogue, the engine, the journal and the transports.

use std::borrow::Borrow;
use std::fmt;
use std::sync::Arc;

/// A rock's catalogue identifier (the catalogue's `id`): not empty, without whitespace or
/// control characters (so it is one token in logs, ROS 2 frame names and file names).
///
/// Checked once, by [`PbrId::parse`], where an id enters (the catalogue, a journal line, a
/// reset request's lookup); a clone shares the text (O(1), no allocation). Compared, ordered
/// and hashed as its text, so a map keyed by `PbrId` is looked up with a `&str` too.
#[derive(
    Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(try_from = "String", into = "String")]
pub struct PbrId(Arc<str>);

/// Why a text is not a rock identifier (messages as the catalogue reports them).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PbrIdError {
    #[error("id must not be empty")]
    Empty,
    #[error("id {id:?} must not contain whitespace or control characters")]
    Whitespace { id: String },
}

impl PbrId {
    /// The one constructor: `text` if it is a valid identifier.
    pub fn parse(text: &str) -> Result<PbrId, PbrIdError> {
        if text.is_empty() {
            return Err(PbrIdError::Empty);
        }
        if text.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(PbrIdError::Whitespace {
                id: text.to_owned(),
            });
        }
        Ok(PbrId(Arc::from(text)))
    }

    /// The identifier's text.
    #[must_use]
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for PbrId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl Borrow<str> for PbrId {
    fn borrow(&self) -> &str {
        &self.0
    }
}

impl PartialEq<str> for PbrId {
    fn eq(&self, other: &str) -> bool {
        &*self.0 == other
    }
}

impl PartialEq<&str> for PbrId {
    fn eq(&self, other: &&str) -> bool {
        &*self.0 == *other
    }
}

impl TryFrom<String> for PbrId {
    type Error = PbrIdError;
    fn try_from(value: String) -> Result<Self, Self::Error> {
        PbrId::parse(&value)
    }
}

impl From<PbrId> for String {
    fn from(value: PbrId) -> Self {
        value.0.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_one_token_of_any_other_characters() {
        for good in ["rrs-slender-pillar", "a", "Ω_1.2/3"] {
            assert_eq!(PbrId::parse(good).unwrap(), good);
        }
        assert_eq!(PbrId::parse(""), Err(PbrIdError::Empty));
        for bad in [
            "two words",
            "tab\there",
            "nl\n",
            "nul\0",
            " lead",
            "nbsp\u{a0}",
        ] {
            assert!(
                matches!(PbrId::parse(bad), Err(PbrIdError::Whitespace { .. })),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn a_clone_shares_the_text_and_serde_keeps_the_string() {
        let id = PbrId::parse("rrs-slender-pillar").unwrap();
        assert!(std::ptr::eq(id.as_str(), id.clone().as_str()));
        let json = serde_json::to_string(&id).unwrap();
        assert_eq!(json, "\"rrs-slender-pillar\"");
        assert_eq!(serde_json::from_str::<PbrId>(&json).unwrap(), id);
        assert!(serde_json::from_str::<PbrId>("\"a b\"").is_err());
        let map = std::collections::HashMap::from([(id, 1)]);
        assert_eq!(map.get("rrs-slender-pillar"), Some(&1));
    }
}
