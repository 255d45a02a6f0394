//! Fitting chains and grids to data: offset metrics, foot points, least squares with
//! parameter correction, Nelder-Mead, BFGS and the evolutionary methods.
