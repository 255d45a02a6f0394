//! Outputs: the JSON report, SVG plots, OBJ/STL meshes and PNG renders.
