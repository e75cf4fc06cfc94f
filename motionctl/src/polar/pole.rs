//! Pole placement (Ch. 4): area error of a digitized contour, the F1 surrogate, and a
//! Hooke-Jeeves search over the machine pole within the work area.
