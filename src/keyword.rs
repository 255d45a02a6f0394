//! Keyword enums: the small enums the command line and the reports name by a word (a method, a
//! norm, a backend, a continuity). Each is declared once with [`keywords!`], which gives it
//! `name()`, `Display` (the name) and a case-insensitive `FromStr` whose error lists the
//! accepted names, so every such enum parses, prints and complains the same way.

use crate::error::{Error, Result};

/// Implements `name()`, `Display` and `FromStr` for a keyword enum.
///
/// `keywords!(Type, "what", { Variant => "name" | "alias", ... })`: the first string of each
/// variant is its name (what `Display` writes and reports carry), the others are accepted
/// spellings. `what` names the enum in errors: `unknown what 'x' (expected a, b or c)`.
/// Write `keywords!(Type, "what", { ... }, parse = manual)` to implement `FromStr` by hand
/// (through [`parse`]), for an enum that explains some rejections.
macro_rules! keywords {
    ($ty:ident, $what:literal, { $($variant:ident => $name:literal $(| $alias:literal)*),+ $(,)? }) => {
        $crate::keyword::keywords!($ty, $what, { $($variant => $name $(| $alias)*),+ }, parse = manual);

        impl std::str::FromStr for $ty {
            type Err = $crate::error::Error;
            fn from_str(s: &str) -> $crate::error::Result<Self> {
                $crate::keyword::parse(s, $what, $ty::KEYWORDS)
            }
        }
    };
    ($ty:ident, $what:literal, { $($variant:ident => $name:literal $(| $alias:literal)*),+ $(,)? }, parse = manual) => {
        impl $ty {
            /// Every value with its accepted spellings, its name first.
            pub const KEYWORDS: &'static [($ty, &'static [&'static str])] =
                &[$(($ty::$variant, &[$name $(, $alias)*])),+];

            /// The name used on the command line and in reports.
            #[must_use]
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name),+
                }
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}
pub(crate) use keywords;

/// The value of `table` one of whose spellings is `s`, ignoring ASCII case; otherwise the
/// error `unknown what 's' (expected a, b or c)`, listing the names.
pub fn parse<T: Copy>(s: &str, what: &str, table: &[(T, &[&str])]) -> Result<T> {
    table
        .iter()
        .find(|(_, spellings)| spellings.iter().any(|n| n.eq_ignore_ascii_case(s)))
        .map(|&(value, _)| value)
        .ok_or_else(|| {
            let names: Vec<&str> = table.iter().map(|(_, spellings)| spellings[0]).collect();
            Error::invalid(format!("unknown {what} '{s}' (expected {})", or_list(&names)))
        })
}

/// `a`, `a or b`, `a, b or c`.
#[must_use]
pub fn or_list(names: &[&str]) -> String {
    match names {
        [] => String::new(),
        [one] => (*one).to_string(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    enum Colour {
        Red,
        DarkBlue,
    }
    keywords!(Colour, "colour", { Red => "red", DarkBlue => "dark-blue" | "navy" });

    #[test]
    fn names_parse_back_in_any_case_and_aliases_are_accepted() {
        for &(c, _) in Colour::KEYWORDS {
            assert_eq!(c.name().parse::<Colour>().unwrap(), c);
            assert_eq!(c.to_string(), c.name());
        }
        assert_eq!("NAVY".parse::<Colour>().unwrap(), Colour::DarkBlue);
        assert_eq!("Red".parse::<Colour>().unwrap(), Colour::Red);
    }

    #[test]
    fn an_unknown_word_lists_the_names() {
        let e = "green".parse::<Colour>().unwrap_err().to_string();
        assert!(
            e.contains("unknown colour 'green' (expected red or dark-blue)"),
            "{e}"
        );
        assert_eq!(or_list(&["a", "b", "c"]), "a, b or c");
        assert_eq!(or_list(&["a"]), "a");
    }
}
