//! Serde through a type's text: a type written and read as words
//! (`Display` and `FromStr`, as controller and action names are)
//! serializes as that text and deserializes by parsing it. It sits in
//! the lowest crate so that every crate above can use it (the policy's
//! device names, the evaluation's controller and action names).

/// Implements `serde::Serialize` (the type's `Display` text) and
/// `serde::Deserialize` (a string parsed by its `FromStr`, the parse
/// error in words) for a type. The calling crate depends on `serde`.
///
/// ```
/// #[derive(Debug, PartialEq)]
/// struct Seed(u32);
/// impl std::fmt::Display for Seed {
///     fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
///         write!(f, "seed-{}", self.0)
///     }
/// }
/// impl std::str::FromStr for Seed {
///     type Err = String;
///     fn from_str(s: &str) -> Result<Self, String> {
///         let n = s.strip_prefix("seed-").ok_or("no seed- prefix")?;
///         n.parse().map(Seed).map_err(|e| format!("{e}"))
///     }
/// }
/// buridan_env::serde_as_text!(Seed);
/// assert_eq!(serde_json::to_string(&Seed(3)).unwrap(), r#""seed-3""#);
/// assert_eq!(serde_json::from_str::<Seed>(r#""seed-7""#).unwrap(), Seed(7));
/// let err = serde_json::from_str::<Seed>(r#""7""#).unwrap_err();
/// assert!(err.to_string().contains("no seed- prefix"), "{err}");
/// ```
#[macro_export]
macro_rules! serde_as_text {
    ($t:ty) => {
        impl ::serde::Serialize for $t {
            fn serialize<S: ::serde::Serializer>(
                &self,
                s: S,
            ) -> ::std::result::Result<S::Ok, S::Error> {
                s.collect_str(self)
            }
        }

        impl<'de> ::serde::Deserialize<'de> for $t {
            fn deserialize<D: ::serde::Deserializer<'de>>(
                d: D,
            ) -> ::std::result::Result<Self, D::Error> {
                let text = <::std::string::String as ::serde::Deserialize>::deserialize(d)?;
                text.parse()
                    .map_err(<D::Error as ::serde::de::Error>::custom)
            }
        }
    };
}
