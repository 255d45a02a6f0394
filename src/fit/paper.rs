//! The paper's three NACA 4413 cases (WCE 2008, Figs. 9–11; `docs/ARCHITECTURE.md` §2.5).

/// One of the paper's 2D cases: its layout, counts and reported total offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperCase {
    /// Case number as in the paper (1, 2, 3).
    pub case: usize,
    /// Degree of every segment.
    pub degree: usize,
    /// Number of chained segments.
    pub segments: usize,
    /// Design points the paper lists.
    pub design_points: usize,
    /// Expanded control points the paper lists.
    pub expanded_points: usize,
    /// The paper's "total offset" over the 82 points (matches a sum of squares at unit chord).
    pub total_offset: f64,
}

/// The three cases, in the paper's order.
pub const PAPER_CASES: [PaperCase; 3] = [
    PaperCase {
        case: 1,
        degree: 3,
        segments: 5,
        design_points: 12,
        expanded_points: 16,
        total_offset: 2.3751e-6,
    },
    PaperCase {
        case: 2,
        degree: 4,
        segments: 3,
        design_points: 11,
        expanded_points: 13,
        total_offset: 0.0018,
    },
    PaperCase {
        case: 3,
        degree: 5,
        segments: 3,
        design_points: 14,
        expanded_points: 16,
        total_offset: 1.2705e-4,
    },
];
