//! Population evaluation: the `PopulationEvaluator` trait with a rayon CPU path and a wgpu
//! GPU path that give the same answers.
