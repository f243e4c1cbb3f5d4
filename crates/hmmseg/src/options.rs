//! The engine's named options: one macro gives every option enum its names, [`FromStr`]
//! (an [`EngineError::InvalidParameter`] naming the option and the allowed values),
//! [`Display`] and the list of all values, so the Rust API, JSON (serde uses the same names)
//! and the Python binding (`typing.Literal` aliases built from [`OptionEnum::NAMES`]) agree.
//!
//! [`FromStr`]: std::str::FromStr
//! [`Display`]: std::fmt::Display
//! [`EngineError::InvalidParameter`]: crate::EngineError::InvalidParameter

/// An enum of named options (implemented by [`option_enum!`](crate::option_enum)).
pub trait OptionEnum: Sized + Copy + 'static {
    /// What the option is called in error messages (`"covariance"`, `"grammar mode"`, ...).
    const OPTION: &'static str;
    /// Every value, in declaration order.
    const ALL: &'static [Self];
    /// The name of every value, in the order of [`OptionEnum::ALL`].
    const NAMES: &'static [&'static str];

    /// The name of this value.
    fn as_str(self) -> &'static str;
}

/// Implement [`OptionEnum`], `as_str`, [`FromStr`](std::str::FromStr) and
/// [`Display`](std::fmt::Display) for a fieldless enum from `Variant => "name"` pairs.
#[macro_export]
macro_rules! option_enum {
    ($ty:ty, $option:literal, [$($variant:ident => $name:literal),+ $(,)?]) => {
        impl $crate::options::OptionEnum for $ty {
            const OPTION: &'static str = $option;
            const ALL: &'static [Self] = &[$(Self::$variant),+];
            const NAMES: &'static [&'static str] = &[$($name),+];

            fn as_str(self) -> &'static str {
                match self {
                    $(Self::$variant => $name),+
                }
            }
        }

        impl $ty {
            /// The name used in JSON and in the Python binding.
            pub fn as_str(self) -> &'static str {
                <Self as $crate::options::OptionEnum>::as_str(self)
            }
        }

        impl ::std::str::FromStr for $ty {
            type Err = $crate::EngineError;

            fn from_str(s: &str) -> ::std::result::Result<Self, Self::Err> {
                match s {
                    $($name => Ok(Self::$variant),)+
                    other => Err($crate::options::unknown::<Self>(other)),
                }
            }
        }

        impl ::std::fmt::Display for $ty {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str(self.as_str())
            }
        }
    };
}

/// The error for a name that is not one of `T`'s values.
#[doc(hidden)]
pub fn unknown<T: OptionEnum>(got: &str) -> crate::EngineError {
    let allowed: Vec<String> = T::NAMES.iter().map(|n| format!("{n:?}")).collect();
    crate::EngineError::InvalidParameter(format!(
        "{} must be one of {}, got {got:?}",
        T::OPTION,
        allowed.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::OptionEnum;
    use crate::features::SizeMeasure;
    use crate::hmm::{CovarianceType, Topology};
    use crate::segment::scorer::EndState;
    use crate::segment::GrammarMode;
    use crate::EngineError;

    /// Every name parses back to its value, matches serde's name, and a wrong name is an
    /// `InvalidParameter` error listing the allowed values.
    fn roundtrip<T>()
    where
        T: OptionEnum
            + std::str::FromStr<Err = EngineError>
            + std::fmt::Debug
            + PartialEq
            + serde::Serialize,
    {
        assert_eq!(T::ALL.len(), T::NAMES.len());
        for (&v, &name) in T::ALL.iter().zip(T::NAMES) {
            assert_eq!(v.as_str(), name);
            assert_eq!(name.parse::<T>().unwrap(), v);
            assert_eq!(serde_json::to_string(&v).unwrap(), format!("{name:?}"));
        }
        match "bogus".parse::<T>() {
            Err(EngineError::InvalidParameter(m)) => {
                assert!(m.starts_with(T::OPTION), "{m}");
                assert!(m.contains(&format!("{:?}", T::NAMES[0])), "{m}");
                assert!(m.ends_with("got \"bogus\""), "{m}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn every_option_enum_parses_its_names() {
        roundtrip::<CovarianceType>();
        roundtrip::<Topology>();
        roundtrip::<GrammarMode>();
        roundtrip::<EndState>();
        roundtrip::<SizeMeasure>();
    }
}
