//! The cameras of a fit of the example's own targets (`--views`, `--view-count`).

use diffsil::pose::fit::{framing_orbit, ring_orbits, RAISED_ELEVATION_DEG};
use diffsil::random::SplitMix64;
use diffsil::{Camera, Mesh, Orbit};

/// Where the cameras sit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Layout {
    /// A ring at the height of the model's centre: opposite views are mirror images.
    Level,
    /// A ring 15° above it, looking down (`RAISED_ELEVATION_DEG`).
    Raised,
    /// A rig drawn at random from the seed, as real capture rigs are placed by hand: each of the
    /// ring's azimuths moved by up to ±25°, elevations from 0° to 30°, distances 1 to 1.25
    /// times the ring's, each camera aimed up to 5% of the framing distance off the model's
    /// centre
    Irregular,
}

/// The cameras of `layout` framing `rest` (the model's rest pose), `views` of them, `size`
/// (width, height) pixels, the body framed in the vertical field of view (`seed` draws the
/// irregular rig), and one line per camera of the irregular rig (azimuth, elevation, distance
/// over the ring's; empty for the rings).
pub fn cameras(layout: Layout, rest: &Mesh, views: u32, size: (u32, u32), seed: u64) -> (Vec<Camera>, String) {
    let elevation = match layout {
        Layout::Level => 0.0,
        Layout::Raised => RAISED_ELEVATION_DEG.to_radians(),
        Layout::Irregular => {
            let level = framing_orbit(rest, 0.0);
            let rig = irregular(level, views, seed);
            let description = rig
                .iter()
                .enumerate()
                .map(|(k, o)| {
                    format!(
                        "camera {k}: azimuth {:.0}°, elevation {:.0}°, {:.2} times the ring's distance\n",
                        o.azimuth.to_degrees(),
                        o.elevation.to_degrees(),
                        o.distance / level.distance
                    )
                })
                .collect();
            return (rig.iter().map(|o| o.camera(size.0, size.1)).collect(), description);
        }
    };
    let ring = ring_orbits(framing_orbit(rest, elevation), views);
    (ring.iter().map(|o| o.camera(size.0, size.1)).collect(), String::new())
}

/// The irregular rig of `seed` about the level framing orbit `level`.
fn irregular(level: Orbit, views: u32, seed: u64) -> Vec<Orbit> {
    let mut rng = SplitMix64::new(seed ^ 0xCA3E_7A5E);
    let degrees = |d: f32| d.to_radians();
    (0..views)
        .map(|k| {
            let aim = rng.unit_vector() * rng.range(0.0, 0.05) * level.distance;
            Orbit {
                target: level.target + aim,
                azimuth: std::f32::consts::TAU * k as f32 / views as f32 + degrees(rng.range(-25.0, 25.0)),
                elevation: degrees(rng.range(0.0, 30.0)),
                distance: level.distance * rng.range(1.0, 1.25),
                ..level
            }
        })
        .collect()
}
