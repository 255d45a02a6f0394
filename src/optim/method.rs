//! The optimisation methods: one enum names every method of every objective (chain and grid
//! fits, aerodynamic shapes). Each objective lists the methods it takes ([`Method::CURVE`],
//! [`Method::SURFACE`], [`Method::AERO`]; the evolutionary driver runs
//! [`Method::EVOLUTIONARY`]) and parses its option with [`Method::parse_among`], so every
//! name, alias and error comes from one table.

use crate::error::Result;
use crate::keyword::{self, keywords};
use serde::{Deserialize, Serialize};

/// An optimisation method.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Method {
    /// Least squares: a linear solve at chord-length parameters, then Levenberg-Marquardt
    /// over the design points and foot points together (closest metric). The default.
    #[default]
    Lsq,
    /// Nelder-Mead on the design variables from the paper's start.
    NelderMead,
    /// BFGS with the analytic gradient from the paper's start.
    Bfgs,
    /// The genetic algorithm on the population evaluator.
    Ga,
    /// CMA-ES on the population evaluator.
    Cmaes,
    /// The genetic algorithm, then the least-squares polish from its best design.
    GaLsq,
    /// CMA-ES, then the least-squares polish from its best design.
    CmaesLsq,
    /// The GA for the first half of the generations, then CMA-ES from its best.
    GaCmaes,
}

keywords!(Method, "method", {
    Lsq => "lsq",
    NelderMead => "nelder-mead" | "neldermead" | "nm",
    Bfgs => "bfgs",
    Ga => "ga",
    Cmaes => "cmaes" | "cma-es",
    GaLsq => "ga+lsq",
    CmaesLsq => "cmaes+lsq" | "cma-es+lsq",
    GaCmaes => "ga+cmaes",
});

impl Method {
    /// The methods of a chain fit, in the order of the paper's comparison table.
    pub const CURVE: &'static [Method] = &[
        Method::NelderMead,
        Method::Bfgs,
        Method::Ga,
        Method::Cmaes,
        Method::GaLsq,
        Method::CmaesLsq,
        Method::Lsq,
    ];

    /// The methods of a patch-grid fit.
    pub const SURFACE: &'static [Method] = &[
        Method::Lsq,
        Method::Ga,
        Method::Cmaes,
        Method::GaLsq,
        Method::CmaesLsq,
    ];

    /// The methods of an aerodynamic optimisation.
    pub const AERO: &'static [Method] = &[Method::Ga, Method::Cmaes, Method::GaCmaes];

    /// The methods the evolutionary driver (`evo::Evolution`) runs.
    pub const EVOLUTIONARY: &'static [Method] = &[Method::Ga, Method::Cmaes];

    /// The evolutionary method this starts with, if any, and whether the least-squares polish
    /// follows it.
    #[must_use]
    pub fn evolutionary(self) -> Option<(Method, bool)> {
        match self {
            Method::Ga | Method::GaCmaes => Some((Method::Ga, false)),
            Method::Cmaes => Some((Method::Cmaes, false)),
            Method::GaLsq => Some((Method::Ga, true)),
            Method::CmaesLsq => Some((Method::Cmaes, true)),
            Method::Lsq | Method::NelderMead | Method::Bfgs => None,
        }
    }

    /// The method `s` names among `accepted` (any case, any alias); otherwise the error
    /// `unknown method 's' (expected a, b or c)`, listing the names of `accepted` in the
    /// table's order.
    pub fn parse_among(s: &str, accepted: &[Method]) -> Result<Method> {
        let table: Vec<(Method, &[&str])> = Method::KEYWORDS
            .iter()
            .filter(|(m, _)| accepted.contains(m))
            .copied()
            .collect();
        keyword::parse(s, "method", &table)
    }

    /// The names of `methods`, in their order.
    #[must_use]
    pub fn names(methods: &[Method]) -> Vec<&'static str> {
        methods.iter().map(|m| m.name()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_each_objective_lists_its_own() {
        for &(m, _) in Method::KEYWORDS {
            assert_eq!(m.to_string().parse::<Method>().unwrap(), m);
        }
        assert!("pso".parse::<Method>().is_err());
        assert_eq!(Method::GaLsq.evolutionary(), Some((Method::Ga, true)));
        assert_eq!(Method::Bfgs.evolutionary(), None);
        assert_eq!(
            Method::parse_among("CMA-ES", Method::AERO).unwrap(),
            Method::Cmaes
        );
        let e = Method::parse_among("lsq", Method::AERO).unwrap_err().to_string();
        assert_eq!(e, "unknown method 'lsq' (expected ga, cmaes or ga+cmaes)");
        let e = Method::parse_among("x", Method::CURVE).unwrap_err().to_string();
        assert_eq!(
            e,
            "unknown method 'x' (expected lsq, nelder-mead, bfgs, ga, cmaes, ga+lsq or cmaes+lsq)"
        );
    }
}
