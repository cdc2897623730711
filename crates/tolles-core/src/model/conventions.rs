//! Frames, axes and units used everywhere in tolles.
//!
//! # Units
//! - magnetic fields: nanotesla (nT);
//! - time: seconds (s); sample rates: hertz (Hz);
//! - angles at interfaces (files, command line): degrees; angles inside the numerics: radians,
//!   and every function says which it takes.
//!
//! # Body frame: FRD
//! - x forward (the patent's **L**, longitudinal),
//! - y right wing (the patent's **T**, transverse),
//! - z down (the patent's **V**, vertical).
//!
//! A fluxgate column triple `PREFIX_x`, `PREFIX_y`, `PREFIX_z` is read as the field in this frame.
//!
//! # Attitude: yaw–pitch–roll (ZYX)
//! - yaw (heading) clockwise from north, seen from above;
//! - pitch nose-up positive;
//! - roll right-wing-down positive.
//!
//! The navigation frame is NED (north, east, down). A vector `n` in NED has body components
//! `b = Rx(roll)ᵀ · Ry(pitch)ᵀ · Rz(yaw)ᵀ · n`.
//!
//! # Earth field direction
//! Inclination (dip) φ is positive when the field points down (northern hemisphere);
//! declination is clockwise from true north. In NED the unit field is
//! `(cos φ cos D, cos φ sin D, sin φ)`.
//!
//! # The aircraft field model
//! The aircraft adds `H = P + I·B + E·dB/dt` to the earth field `B` (body frame), where
//! - `P` is the permanent field (nT),
//! - `I[i][j]` is the induced field along axis i per unit earth field along axis j (dimensionless),
//! - `E[i][j]` is the eddy-current field along axis i (nT) per unit rate of change of the earth
//!   field along axis j (nT/s), so `E` is in seconds.
//!
//! A scalar magnetometer reads `|B + H| ≈ |B| + B̂·H`, which is what the Tolles-Lawson design
//! matrix linearises.
//!
//! # The patent's nomenclature (US 2,692,970)
//! Axes L = x, T = y, V = z. Induced double letters name the inducing earth component first and
//! the induced field second, so only symmetric sums are observable: `TL+LT = I[x][y] + I[y][x]`,
//! `TV+VT = I[y][z] + I[z][y]`, `LV+VL = I[x][z] + I[z][x]`, `VV−TT = I[z][z] − I[y][y]`,
//! `VV−LL = I[z][z] − I[x][x]`. Eddy double letters likewise: patent `ab = E[b][a]`
//! (first letter the earth component whose change drives the current, second the direction of
//! the eddy field), e.g. `tl = E[x][y]`, `vt = E[y][z]`, `vv−tt = E[z][z] − E[y][y]`.
//! The trace of `I` and of `E` is not observable by a scalar magnetometer: it adds `|B|` and
//! `d|B|/dt` times a constant, which carry no attitude signal.
//!
//! # The patent's angles
//! The patent writes the field's direction cosines (its equations 4 for rolls and 5 for
//! pitches) in its own angles. Matched against [`crate::flight::attitude::Attitude::to_body`] (tested
//! in [`crate::patent`]):
//! - heading θp = −yaw: the patent counts its heading counter-clockwise from magnetic north;
//! - roll ψ = roll: right wing down positive in both;
//! - pitch λ = −pitch: the patent's pitch is nose-down positive;
//! - cos X = B̂_y (T), cos Y = B̂_x (L), cos Z = B̂_z (V), with the dip φ positive down.
//!
//! (Keeping the patent's angles and pointing its T axis to the left would fit equations 4 and 5
//! as well; we keep T = y and convert the angles instead.) The patent's eddy-current equations
//! 6 and 7, and its tables, equal `−B̂·E·dB̂/dt`: its eddy coefficients carry the opposite
//! sign to `E` (Lenz's), `ab (patent) = −E[b][a]`, while [`crate::model::interpret`] reports `E[b][a]`
//! under the patent's letters. [`crate::patent::closed_form`] converts angles and signs.
