//! Schiller–Naumann drag on a dispersed field of spheres of diameter d.
//!
//! The FIRST field of `between` is the fluid (ρ_f, θ_f), the second the particles. With
//! Re = ρ_f |Δu| d / μ, Δu = u_f − u_s the (interstitial) face slip, Schiller & Naumann
//! (1933), as given by Clift, Grace & Weber (1978), *Bubbles, Drops and Particles*:
//!
//! ```text
//!     C_D = 24/Re (1 + 0.15 Re^0.687)   Re ≤ 1000
//!     C_D = 0.44                        Re > 1000
//! ```
//!
//! The per-particle drag F = ½ ρ_f C_D (πd²/4) |Δu| Δu over particle volume πd³/6 gives
//! (see the derivation in [`super::drag`], K = F/(V_p θ_f |Δu|)):
//!
//! ```text
//!     K = (3/4) C_D Re μ / (d² θ_f) = 18 μ/(d² θ_f) · (1 + 0.15 Re^0.687)     (Re ≤ 1000)
//!                                   = 0.33 Re μ / (d² θ_f)                    (Re > 1000)
//! ```
//!
//! which tends to the Stokes value 18μ/(d²θ_f) as Re → 0. The switch at Re = 1000 has a
//! jump: 24(1 + 0.15·1000^0.687)/1000 = 0.43829 against 0.44, i.e. K rises by 0.391 % there.
//!
//! With `di_felice: true` the drag is that of Di Felice (1994) for dense suspensions, at
//! the superficial slip θ_f |Δu| (Re_s = θ_f Re) times θ_f^(−χ(Re_s)),
//! χ = 3.7 − 0.65 exp(−(1.5 − log₁₀ Re_s)²/2):
//! K = (3/4) C_D(Re_s) Re_s μ θ_f^(−χ) / d². It equals the plain law at θ_f = 1.

use super::drag::{Drag, DragCorrelation, Shape};
use multifield_core::math::Real;

/// Reynolds number above which C_D = 0.44.
pub const RE_SWITCH: Real = 1000.0;

/// C_D·Re of the Schiller–Naumann law (24 at Re → 0).
pub fn cd_re(re: Real) -> Real {
    if re <= RE_SWITCH {
        24.0 * (1.0 + 0.15 * re.powf(0.687))
    } else {
        0.44 * re
    }
}

/// The Schiller–Naumann correlation for spheres.
#[derive(Clone, Copy, Debug, Default)]
pub struct SchillerNaumann;

impl DragCorrelation for SchillerNaumann {
    const NAME: &'static str = "schiller_naumann";
    const SUMMARY: &'static str =
        "Schiller–Naumann drag on spheres (fluid = first field): CD = 24/Re(1 + 0.15Re^0.687), 0.44 above Re 1000";
    const CITATION: &'static str = "Schiller & Naumann (1933), Z. Ver. Dtsch. Ing. 77, 318; as given by Clift, \
                                    Grace & Weber (1978), Bubbles, Drops and Particles";
    const SHAPE: Shape = Shape::Sphere;
    const VALID_RE: (Real, Real) = (0.0, 2e5);
    fn cd_re(re: Real, _theta_f: Real) -> Real {
        cd_re(re)
    }
}

multifield_core::register!(
    Exchange,
    "schiller_naumann",
    Drag<SchillerNaumann>,
    SchillerNaumann::SUMMARY,
    Drag::<SchillerNaumann>::PARAMS
);

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;

    fn law(di_felice: bool) -> Drag<SchillerNaumann> {
        Drag { di_felice, ..Drag::new(0.1, 0.01) }
    }

    #[test]
    fn hand_computed_values() {
        // ρ_f = 1, d = 0.1, μ = 0.01: Re = 10 |Δu|; 18μ/d² = 18
        let m = law(false);
        // Re → 0: Stokes (Re floored at 1e-12 adds 18·0.15·1e-12^0.687 = 1.6e-8)
        assert!((m.coefficient(0.0, 1.0, 1.0) - 18.0).abs() < 1e-7);
        // Re = 1: 18 (1 + 0.15) = 20.7
        assert!((m.coefficient(0.1, 1.0, 1.0) - 20.7).abs() < 1e-12);
        // Re = 100: 100^0.687 = 23.659 (10^1.374); K = 18 (1 + 0.15·23.659)/0.8 at θ_f = 0.8
        let p = 10f64.powf(1.374);
        assert!((p - 23.6592).abs() < 1e-3);
        assert!((m.coefficient(10.0, 1.0, 0.8) - 18.0 * (1.0 + 0.15 * p) / 0.8).abs() < 1e-10);
        // Re = 2000: C_D = 0.44, K = 0.75 · 0.44 · 2000 · μ/d² = 660
        assert!((m.coefficient(200.0, 1.0, 1.0) - 660.0).abs() < 1e-9);
        // density enters through Re only: ρ_f = 2, |Δu| = 5 is Re = 100 too
        assert!((m.coefficient(5.0, 2.0, 1.0) - m.coefficient(10.0, 1.0, 1.0)).abs() < 1e-12);
    }

    #[test]
    fn switch_at_re_1000_jumps_by_0_4_percent() {
        let below = cd_re(RE_SWITCH);
        let above = cd_re(RE_SWITCH * (1.0 + 1e-12));
        let jump = (above - below) / below;
        assert!((jump - 0.00391).abs() < 5e-5, "jump {jump}");
        // smooth elsewhere: a relative step of 1e-9 in Re changes C_D·Re by ~1e-9
        for re in [1e-6, 0.5, 1.0, 10.0, 999.0, 2000.0] {
            let r = (cd_re(re * (1.0 + 1e-9)) - cd_re(re)) / cd_re(re);
            assert!(r.abs() < 2e-9, "Re {re}: {r}");
        }
    }

    #[test]
    fn di_felice_is_neutral_at_theta_one_and_hinders_below() {
        for slip in [0.0, 0.01, 1.0, 10.0, 1e3] {
            let (a, b) = (law(false).coefficient(slip, 1.0, 1.0), law(true).coefficient(slip, 1.0, 1.0));
            assert!((a - b).abs() <= 1e-14 * a, "slip {slip}: {a} vs {b}");
        }
        // θ_f = 0.5, slip 6.32456 → Re = 63.2456, Re_s = 31.6228 = 10^1.5: χ = 3.05
        let slip = 2.0 * 10f64.powf(1.5) / 10.0;
        let k = law(true).coefficient(slip, 1.0, 0.5);
        let re_s = 10f64.powf(1.5);
        let by_hand = 18.0 * (1.0 + 0.15 * re_s.powf(0.687)) * 0.5f64.powf(-3.05);
        assert!((k - by_hand).abs() < 1e-9 * by_hand, "{k} vs {by_hand}");
        assert!(k > law(false).coefficient(slip, 1.0, 0.5));
    }
}
