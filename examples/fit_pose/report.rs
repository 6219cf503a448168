//! What a single fit of the example prints after it ends: the swap test, the crossed legs, the
//! pass from the runner-up facing, the restart and the polish.

use diffsil::pose::fit::{Fitted, RestartStart};

/// An energy, or "-" where there is none.
fn energy(e: Option<f64>) -> String {
    e.map_or("-".to_string(), |e| format!("{e:.3e}"))
}

/// Prints the swap test's candidates, the crossed legs' energies and runs, the pass from the
/// runner-up facing, the misfit check and restart and the polish of `fitted`, where they ran.
pub fn print_fitted(fitted: &Fitted) {
    if let Some(report) = &fitted.first.swap {
        let candidates: Vec<String> = report
            .candidates
            .iter()
            .map(|c| format!("{:?} {} → {}", c.kind, energy(c.start_energy), energy(c.energy)))
            .collect();
        println!(
            "swap test: pose {} → {:.3e}, kept {:?} (candidates: {})",
            energy(report.start_energy),
            report.energy,
            report.kept,
            candidates.join(", ")
        );
    }
    if let Some(c) = &fitted.first.crossed_legs {
        println!(
            "crossed legs: fitted {:.3e}, crossed pose {:.3e}, refined {} ({:.2} times the error where they differ, \
             {:.3} more per pixel there), runs from it → {}; the fit ends at {:?}",
            c.fitted_energy,
            c.start_energy,
            energy(c.refined_energy),
            c.changed_ratio,
            c.changed_excess,
            c.runs.iter().map(|r| format!("{:?} {}", r.start, energy(r.energy))).collect::<Vec<_>>().join(", "),
            c.end
        );
    }
    if let Some(f) = &fitted.facing_run {
        println!(
            "runner-up facing {:.0}° ({:.3} times the chosen facing's energy after the first steps): its pass {} \
             steps, energy {:.3e} → {}, {}",
            f.facing.to_degrees(),
            f.ratio,
            f.pass.steps(),
            f.first_energy,
            energy(f.energy),
            if f.kept { "kept" } else { "not kept" }
        );
    }
    if let Some(r) = &fitted.restart {
        let check = format!("misfit blocks {:?}{}", r.misfit_blocks, if r.thinned { ", targets thinned" } else { "" });
        if r.runs.is_empty() {
            println!("{check}: no restart");
        }
        for (k, run) in r.runs.iter().enumerate() {
            let from = match run.start {
                RestartStart::Family(family) => format!(
                    "leg stride {} / arm swing {}{}",
                    family.leg_stride,
                    family.arm_swing,
                    if family.coarse_proxy { "" } else { " without the coarse proxy" }
                ),
                RestartStart::LowestEnd => "the lowest end, without the coarsest stage".to_string(),
            };
            println!(
                "{check}: restart from {from}, {} steps, energy {:.3e} → {}, {}",
                run.pass.steps(),
                r.first_energy,
                energy(run.energy),
                if r.kept == Some(k) { "kept" } else { "not kept" }
            );
        }
    }
    if let Some(p) = &fitted.polish {
        println!(
            "polish: {} steps, energy {:.3e} → {:.3e}, {}",
            p.steps,
            p.energy_before,
            p.energy_after,
            if p.kept { "kept" } else { "not kept" }
        );
    }
}
