//! How many segments a chain fit may have: a layout's design points must not outnumber the data
//! points that determine them; when they do, the most segments that fit at the degree, by
//! bisection (design points grow with the segments).

use crate::chain::{ChainLayout, Continuity};
use crate::error::Error;

/// Why a chain layout is refused for the data.
#[derive(Debug)]
pub enum SegmentsRefused {
    /// The layout cannot be built (a degree or continuity it does not take).
    Layout(Error),
    /// More design points than data points: `design` says how many, `most` is the most
    /// segments that fit at the degree (0: none).
    TooMany {
        /// `degree 7 with 40 segments has 242 design points`, or for far too many segments
        /// (refused before the layout is built) `5000 segments need more than 5000 design
        /// points`.
        design: String,
        /// The most segments whose design points the data determine.
        most: usize,
    },
}

/// The uniform layout of `segments` segments of `degree` and `continuity` for `points` data
/// points, or why it is refused.
pub fn check_segments(
    degree: usize,
    segments: usize,
    continuity: Continuity,
    points: usize,
) -> Result<ChainLayout, SegmentsRefused> {
    let too_many = |design: String| SegmentsRefused::TooMany {
        design,
        most: most_segments(degree, continuity, points, points.min(segments)),
    };
    // Each segment adds at least one design point: far too many are refused before the layout
    // is built.
    if segments > 4 * points.max(64) {
        return Err(too_many(format!(
            "{segments} segments need more than {segments} design points"
        )));
    }
    let layout = ChainLayout::uniform(degree, segments, continuity).map_err(SegmentsRefused::Layout)?;
    if layout.design_count() > points {
        return Err(too_many(format!(
            "degree {degree} with {segments} segments has {} design points",
            layout.design_count()
        )));
    }
    Ok(layout)
}

/// The most segments, at most `below`, of a layout of `degree` and `continuity` whose design
/// points `points` data points determine (0 when not even one segment's).
#[must_use]
pub fn most_segments(degree: usize, continuity: Continuity, points: usize, below: usize) -> usize {
    let fits =
        |s: usize| ChainLayout::uniform(degree, s, continuity).is_ok_and(|l| l.design_count() <= points);
    let (mut lo, mut hi) = (0, below);
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    lo
}

#[cfg(test)]
mod tests {
    use super::*;

    /// C1 cubics have `2 s + 2` design points: 82 points take 40 segments, not 41; the search
    /// agrees with counting up, and refusals say why.
    #[test]
    fn the_most_segments_are_those_whose_design_points_the_data_determine() {
        assert_eq!(most_segments(3, Continuity::C1, 82, 82), 40);
        for (degree, points) in [(2, 10), (3, 82), (5, 30), (7, 82), (7, 7)] {
            let counted = (0..=points)
                .filter(|&s| {
                    ChainLayout::uniform(degree, s, Continuity::C1).is_ok_and(|l| l.design_count() <= points)
                })
                .max()
                .unwrap_or(0);
            assert_eq!(most_segments(degree, Continuity::C1, points, points), counted);
        }
        assert!(check_segments(3, 40, Continuity::C1, 82).is_ok());
        match check_segments(7, 40, Continuity::C1, 82) {
            Err(SegmentsRefused::TooMany { design, most }) => {
                assert_eq!(design, "degree 7 with 40 segments has 242 design points");
                assert_eq!(most, 13);
            }
            other => panic!("{other:?}"),
        }
        match check_segments(3, 500, Continuity::C1, 82) {
            Err(SegmentsRefused::TooMany { design, most }) => {
                assert_eq!(design, "500 segments need more than 500 design points");
                assert_eq!(most, 40);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            check_segments(1, 3, Continuity::C2, 82),
            Err(SegmentsRefused::Layout(_))
        ));
    }
}
