//! The limb swap test on a final pose ([`PoseFit::swap_limbs`]): the discrete mistakes descent
//! cannot undo (a limb on the wrong side of the body's coronal plane, an arm left in that plane
//! behind the torso where it should reach forward or back, a forearm bent the wrong way round,
//! the legs holding each other's places) are tried as candidates, refined a few steps beside the
//! pose itself, and kept only where the energy ends lower.
//!
//! A candidate changes a limb's rotations, not its vertices: each joint `k` of the limb has a
//! world rotation `Q_k` at the pose and `Q⁰_k` at rest, so the limb part moved by
//! `T_k = Q_k Q⁰_kᵀ`. Mirroring the limb in a plane with unit normal `n` (reflection
//! `M = I − 2nnᵀ`) replaces every `T_k` of the limb by `M T_k M` (a proper rotation); exchanging
//! two limbs gives each one the other's `T`, mirrored in the sagittal plane; swinging a limb by a
//! rotation `S` about an axis through its first joint replaces every `T_k` by `S T_k` (turning a
//! forearm is the same below the elbow, the axis along the upper arm). The new joint offsets
//! follow from `R(θ'_k) = Q⁰_kᵀ T'_pᵀ T'_k Q⁰_k` (`p` the parent), which gives back `θ_k` where
//! nothing changed.

use glam::{Mat3, Mat4, Quat, Vec3};

use super::hypotheses::Hypothesis;
use super::{FitState, PoseFit};
use crate::pose::fit::poses::{mirrored_pairs, shoulder};
use crate::pose::skin::{Pose, SkinnedMesh};
use crate::{Error, Result};

/// Largest reach of an arm off the body's coronal plane, as a fraction of its length, for which
/// [`limb_swaps`] swings it besides mirroring it (sin 15°).
const IN_PLANE: f32 = 0.26;

/// Angle of a [`LimbSwap::Swing`], radians (40°).
const SWING_ANGLE: f32 = 0.7;

/// One discrete change [`PoseFit::swap_limbs`] tries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimbSwap {
    /// The limb starting at this joint (a thigh or an upper arm) mirrored front to back, in the
    /// body's coronal plane through the joint.
    Mirror(usize),
    /// Both legs mirrored front to back.
    MirrorLegs,
    /// The arm starting at this joint swung forward (`true`) or back by 40° about the axis
    /// through the joint across the arm in the coronal plane (its far end moves forward or
    /// back): extra candidates for an arm that lies within 15° of that plane.
    Swing(usize, bool),
    /// The legs exchanged: each takes the other's rotations, mirrored left to right.
    ExchangeLegs,
    /// The forearm below this elbow joint turned about its upper arm's line by this many
    /// quarter turns (1, 2 or 3): an elbow bent the wrong way round, which the views can leave
    /// unseen where the forearm hides behind the torso in some of them.
    Twist(usize, u8),
    /// The head and neck turned about the neck's line by this many twelfths of a turn (−2, −1,
    /// 1 or 2: ±30° or ±60°; positive counterclockwise seen from the head's end): a head left
    /// turned the wrong way, whose outline changes slowly under the turn. Only tried when asked
    /// ([`head_turns`];
    /// [`FitOptions::head_turn_below`](crate::pose::fit::FitOptions::head_turn_below)).
    HeadTurn(i8),
}

/// One candidate of [`PoseFit::swap_limbs`] and its energies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwapCandidate {
    /// What it changes.
    pub kind: LimbSwap,
    /// Its energy ([`PoseFit::energy`]) as it is, before any step; `None` where it was not
    /// needed (every candidate refined).
    pub start_energy: Option<f64>,
    /// Its energy after the refinement steps; `None` for a candidate the screening left out.
    pub energy: Option<f64>,
}

/// Which candidates of [`PoseFit::swap_limbs`] take the refinement steps, by their energy
/// ([`PoseFit::energy`]) as they are: the `lowest` ones, and every other whose energy is at most
/// `within` times the pose's own as it is. [`SwapScreen::ALL`] refines every candidate and takes
/// no energy first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwapScreen {
    /// How many of the lowest candidates are refined.
    pub lowest: usize,
    /// A candidate whose energy is at most this multiple of the pose's is refined too (≥ 0;
    /// 0 adds none).
    pub within: f64,
}

impl SwapScreen {
    /// Every candidate refined, none screened.
    pub const ALL: SwapScreen = SwapScreen { lowest: usize::MAX, within: f64::INFINITY };
}

impl Default for SwapScreen {
    /// The lowest, and any other within three times the pose's energy. Over 386 fits (MakeHuman
    /// body, built-in figure, RiggedFigure, CesiumMan's walk; clean, dilated, eroded and noisy
    /// masks), the candidate the full test kept ranked at most third as it was, or lay within
    /// 1.95 times the pose's energy; the three lowest with the ratio kept the same candidate in
    /// every one of them. The lowest with the ratio then ended every row of the evaluation in
    /// `docs/pose-fit-evaluation.md` (352 fits, held-out seeds included) with the same median,
    /// p90, worst case and failures as the three lowest, and each of the 100 fits compared one by
    /// one with the same error and kept swap: a candidate ranked second or third that wins lies
    /// within three times the pose's energy. Measured before the forearm turns
    /// ([`LimbSwap::Twist`]) joined the candidates; with them, over the built-in figure's seeds
    /// 181–330, the screen and the full test ended 149 of the 150 fits the same and with the
    /// same median, p90, worst case and failures (seed 279: 12.0 mm screened, 15.1 mm with
    /// every candidate refined, whose lower energy lay further from the truth), at 0.73 against
    /// 1.05 s of CPU per fit.
    fn default() -> Self {
        SwapScreen { lowest: 1, within: 3.0 }
    }
}

/// How [`PoseFit::swap_limbs`] runs; `SwapTest::default()` is the test [`fit`](crate::pose::fit::fit)
/// runs with `FitOptions::default()` ([`FitOptions::swap_test`](crate::pose::fit::FitOptions::swap_test)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwapTest {
    /// Unblurred steps each refined candidate and the pose itself take; 0 compares every
    /// candidate as it is. Default [`FitOptions::SWAP_STEPS`](crate::pose::fit::FitOptions::SWAP_STEPS).
    pub steps: u32,
    /// Which candidates take the steps. Default [`SwapScreen::default`].
    pub screen: SwapScreen,
    /// Head turns ([`head_turns`]) join the candidates where this is above 0, each kept only
    /// where its energy ends at most this multiple of the pose's; in [0, 1]. Default 0 (see
    /// [`FitOptions::head_turn_below`](crate::pose::fit::FitOptions::head_turn_below)).
    pub head_turn_below: f64,
}

impl Default for SwapTest {
    fn default() -> Self {
        SwapTest {
            steps: crate::pose::fit::FitOptions::SWAP_STEPS,
            screen: SwapScreen::default(),
            head_turn_below: 0.0,
        }
    }
}

impl SwapTest {
    /// Errors ([`Error::InvalidSettings`]) on a negative or NaN `screen.within` and on a
    /// `head_turn_below` outside [0, 1] (NaN included).
    pub fn validate(&self) -> Result<()> {
        let within = self.screen.within;
        if within.is_nan() || within < 0.0 {
            return Err(Error::InvalidSettings(format!("the swap screen's ratio must be ≥ 0, got {within}")));
        }
        let below = self.head_turn_below;
        if !(0.0..=1.0).contains(&below) {
            return Err(Error::InvalidSettings(format!("the head turns' bound must be in [0, 1], got {below}")));
        }
        Ok(())
    }
}

/// What [`PoseFit::swap_limbs`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct SwapReport {
    /// The energy ([`PoseFit::energy`]) of the pose itself after the refinement steps.
    pub energy: f64,
    /// The pose's energy as it is, when the candidates were screened; `None` otherwise.
    pub start_energy: Option<f64>,
    /// Every candidate, in the order of [`limb_swaps`].
    pub candidates: Vec<SwapCandidate>,
    /// The candidate kept (its energy below `energy` and every other refined candidate's);
    /// `None`: the pose stayed on its side.
    pub kept: Option<LimbSwap>,
}

impl PoseFit {
    /// The swap test on the current pose: the [`limb_swaps`] candidates (and, where
    /// [`SwapTest::head_turn_below`] > 0, the [`head_turns`] after them) are screened by their
    /// energy as they are ([`PoseFit::energy`], the pose and every candidate in one render batch;
    /// see [`SwapScreen`]), those that pass and the pose itself take [`SwapTest::steps`]
    /// unblurred steps (in lock-step, one render batch per step, each with the current Adam
    /// moments and nuisances), and the fit moves to the one with the lowest energy; a candidate
    /// is kept only when its energy is strictly below the pose's own after the same steps, a
    /// head turn only when it is also at most `head_turn_below` times the pose's. Each state's
    /// steps are the same bits whichever others run beside it, so screening changes the outcome
    /// only where the best candidate is screened out. Leaves the blur at 0. With 0 steps every
    /// candidate is compared as it is. A skeleton without a pair of legs or arms has no
    /// candidates: the pose then takes the steps alone. Errors where `test` is invalid
    /// ([`SwapTest::validate`]).
    pub fn swap_limbs(&mut self, test: &SwapTest) -> Result<SwapReport> {
        test.validate()?;
        let SwapTest { steps, screen, head_turn_below } = *test;
        let base = self.state();
        let pose = self.pose();
        let mut swaps = limb_swaps(&self.model, &pose)?;
        if head_turn_below > 0.0 {
            swaps.extend(head_turns(&self.model, &pose)?);
        }
        let states: Vec<FitState> = swaps.iter().map(|(_, candidate)| self.with_pose(&base, candidate)).collect();
        let mut candidates: Vec<SwapCandidate> =
            swaps.iter().map(|(kind, _)| SwapCandidate { kind: *kind, start_energy: None, energy: None }).collect();
        self.set_blur(0.0)?;
        // The candidates to refine, in the order of `limb_swaps`.
        let mut start_energy = None;
        let chosen: Vec<usize> = if steps == 0 || screen.lowest < candidates.len() {
            let mut all = vec![base.clone()];
            all.extend(states.iter().cloned());
            let energies = self.energies(&all)?;
            start_energy = Some(energies[0]);
            for (candidate, &energy) in candidates.iter_mut().zip(&energies[1..]) {
                candidate.start_energy = Some(energy);
            }
            let energy = |k: usize| energies[k + 1];
            let mut order: Vec<usize> = (0..candidates.len()).collect();
            order.sort_by(|&a, &b| energy(a).total_cmp(&energy(b)).then(a.cmp(&b)));
            let mut chosen: Vec<usize> = order
                .iter()
                .enumerate()
                .filter(|&(rank, &k)| steps == 0 || rank < screen.lowest || energy(k) <= screen.within * energies[0])
                .map(|(_, &k)| k)
                .collect();
            chosen.sort_unstable();
            chosen
        } else {
            (0..candidates.len()).collect()
        };
        let mut starts = vec![base.clone()];
        starts.extend(chosen.iter().map(|&k| states[k].clone()));
        let results: Vec<Hypothesis> = if steps == 0 {
            self.set_state(base.clone())?;
            let energy = start_energy.expect("screened");
            let mut out = vec![Hypothesis { steps: Vec::new(), energy, state: base }];
            out.extend(chosen.iter().zip(starts.into_iter().skip(1)).map(|(&k, state)| Hypothesis {
                steps: Vec::new(),
                energy: candidates[k].start_energy.expect("screened"),
                state,
            }));
            out
        } else {
            self.run_states(starts, 0.0, steps)?
        };
        for (&k, h) in chosen.iter().zip(&results[1..]) {
            candidates[k].energy = Some(h.energy);
        }
        let mut best = 0;
        for (k, h) in results.iter().enumerate().skip(1) {
            let head = matches!(candidates[chosen[k - 1]].kind, LimbSwap::HeadTurn(_));
            if h.energy < results[best].energy && (!head || h.energy <= head_turn_below * results[0].energy) {
                best = k;
            }
        }
        let report = SwapReport {
            energy: results[0].energy,
            start_energy,
            kept: (best > 0).then(|| candidates[chosen[best - 1]].kind),
            candidates,
        };
        let state = results.into_iter().nth(best).expect("the pose itself is always there").state;
        self.set_state(state)?;
        Ok(report)
    }

    /// `base` with `pose` in place of its own (its shape, Adam moments and nuisances kept), as
    /// the swap test starts a candidate.
    fn with_pose(&self, base: &FitState, pose: &Pose) -> FitState {
        let mut state = base.clone();
        state.params[..self.pose_len].copy_from_slice(&pose.to_params());
        // The last self-intersection check was of the other pose.
        state.intersection = None;
        state
    }

    /// `pose` refined `steps` unblurred steps from `base` as the swap test refines a candidate
    /// ([`PoseFit::with_pose`]): the refined state and its energy. Leaves the blur at 0 and the
    /// fit at some state of the refinement (set the one wanted after).
    pub(in crate::pose::fit) fn refine_pose(&mut self, base: FitState, pose: &Pose, steps: u32) -> Result<Hypothesis> {
        let start = self.with_pose(&base, pose);
        let mut refined = self.run_states(vec![start], 0.0, steps)?;
        Ok(refined.pop().expect("one state in, one out"))
    }
}

/// The candidates of the swap test at `pose`: each leg and each arm mirrored front to back (the
/// arms from the shoulder, past a collar bone), both legs mirrored, and the legs exchanged. An
/// arm that reaches at most 15° off the coronal plane nearly mirrors onto itself; it is also
/// swung 40° forward and 40° back ([`LimbSwap::Swing`]), about the axis across it in that plane
/// (an arm fitted alongside the torso, hidden behind it in the side views, where the target's
/// reaches forward, gets no silhouette gradient to bring it out). Each forearm is also turned
/// about its upper arm's line by a quarter, a half and three quarters of a turn
/// ([`LimbSwap::Twist`]; the elbow is the arm's first joint's child with the most joints below
/// it): a bent forearm's hand goes round that line, a straight one's hardly moves but its
/// refinement steps start from a turned elbow. The
/// legs and arms are the mirrored pairs of [`limb_swing_hypotheses`](crate::pose::fit::limb_swing_hypotheses);
/// the coronal plane is spanned by the line through the hips and the line from the hips' to the
/// shoulders' midpoint (the pose's vertical axis when there are no arms). Only the limbs' joint
/// rotations change. A skeleton without legs gets none; without arms, only the legs'.
pub fn limb_swaps(model: &SkinnedMesh, pose: &Pose) -> Result<Vec<(LimbSwap, Pose)>> {
    pose.validate(model.joint_count())?;
    let pairs = mirrored_pairs(model);
    let Some(&(left_leg, right_leg)) = pairs.first() else { return Ok(Vec::new()) };
    let arms = pairs.get(1).map(|&(a, b)| (shoulder(model, a), shoulder(model, b)));
    let (rest_rot, moved, posed) = world_rotations(model, pose)?;
    let at = |j: usize| posed[j].w_axis.truncate();
    let lateral = at(left_leg) - at(right_leg);
    let hips = 0.5 * (at(left_leg) + at(right_leg));
    let up = match arms {
        Some((a, b)) => 0.5 * (at(a) + at(b)) - hips,
        None => Quat::from_scaled_axis(pose.orientation) * Vec3::Y,
    };
    let forward = lateral.cross(up).normalize_or_zero();
    let sideways = up.cross(forward).normalize_or_zero();
    if forward == Vec3::ZERO || sideways == Vec3::ZERO {
        return Ok(Vec::new());
    }
    let coronal = reflection(forward);
    let sagittal = reflection(sideways);
    let parents = &model.skeleton.parents;
    let n = parents.len();
    let mirror = |limbs: &[usize]| {
        let (mut t, mut changed) = (moved.clone(), vec![false; n]);
        for &limb in limbs {
            for k in subtree(parents, limb) {
                t[k] = coronal * moved[k] * coronal;
                changed[k] = true;
            }
        }
        (t, changed)
    };
    let mut swaps = Vec::new();
    let mut limbs = vec![left_leg, right_leg];
    if let Some((a, b)) = arms {
        limbs.extend([a, b]);
    }
    // How far a limb reaches off the coronal plane, as a fraction of its length, and the offset
    // of its far end (the joint of its subtree farthest from its first joint).
    let reach = |limb: usize, joints: &[usize]| {
        let (mut reach, mut tip) = (0.0f32, Vec3::ZERO);
        for &k in joints {
            let offset = at(k) - at(limb);
            reach = reach.max(offset.dot(forward).abs());
            if offset.length() > tip.length() {
                tip = offset;
            }
        }
        (reach / tip.length().max(f32::MIN_POSITIVE), tip)
    };
    for (i, &limb) in limbs.iter().enumerate() {
        let is_arm = i >= 2;
        let joints = subtree(parents, limb);
        let (off_plane, tip) = reach(limb, &joints);
        swaps.push((LimbSwap::Mirror(limb), mirror(&[limb])));
        // An arm near the coronal plane mirrors nearly onto itself: it is swung as well, about the
        // axis across it in that plane (a turn by +angle about `tip × forward` takes `tip` towards
        // `forward`), whether it hangs or is raised sideways.
        let axis = tip.cross(forward).normalize_or_zero();
        if is_arm && off_plane <= IN_PLANE && axis != Vec3::ZERO {
            for forward_swing in [true, false] {
                let angle = if forward_swing { SWING_ANGLE } else { -SWING_ANGLE };
                let turn = Mat3::from_axis_angle(axis, angle);
                swaps.push((LimbSwap::Swing(limb, forward_swing), turned(&moved, &joints, turn)));
            }
        }
        if is_arm {
            swaps.extend(forearm_twists(parents, limb, &at, &moved));
        }
    }
    swaps.push((LimbSwap::MirrorLegs, mirror(&[left_leg, right_leg])));
    if let Some(pairs) = matched_subtrees(parents, left_leg, right_leg) {
        let (mut t, mut changed) = (moved.clone(), vec![false; n]);
        for (a, b) in pairs {
            t[a] = sagittal * moved[b] * sagittal;
            t[b] = sagittal * moved[a] * sagittal;
            changed[a] = true;
            changed[b] = true;
        }
        swaps.push((LimbSwap::ExchangeLegs, (t, changed)));
    }
    Ok(swaps.into_iter().map(|(kind, changed)| (kind, candidate_pose(pose, parents, &rest_rot, changed))).collect())
}

/// `pose` with the joint rotations of a candidate's changed joints set from its world rotations
/// relative to rest. Candidates change whole subtrees, whose roots' parents keep their rotations.
fn candidate_pose(pose: &Pose, parents: &[Option<usize>], rest_rot: &[Mat3], (t, changed): ChangedRotations) -> Pose {
    let mut out = pose.clone();
    for k in (0..t.len()).filter(|&k| changed[k]) {
        out.joint_rotations[k] = joint_rotation(parents, rest_rot, &t, k);
    }
    out
}

/// The head turns the swap test tries when asked ([`PoseFit::swap_limbs`],
/// [`FitOptions::head_turn_below`](crate::pose::fit::FitOptions::head_turn_below)): the head
/// is every joint below the one child of the arms' shared parent that is not an arm (the neck
/// beside the collars or the shoulders), turned about the line from that joint to the head's
/// joint farthest from it (the pose's vertical axis where the head is a single joint) by −60°,
/// −30°, 30° and 60° ([`LimbSwap::HeadTurn`]). The arms are the second mirrored pair of
/// [`limb_swing_hypotheses`](crate::pose::fit::limb_swing_hypotheses). None where the skeleton
/// has no arms, the arms' first joints have different parents, or that parent has no other
/// child or more than one. Only the head's joint rotations change.
pub fn head_turns(model: &SkinnedMesh, pose: &Pose) -> Result<Vec<(LimbSwap, Pose)>> {
    pose.validate(model.joint_count())?;
    let parents = &model.skeleton.parents;
    let Some(&(a, b)) = mirrored_pairs(model).get(1) else { return Ok(Vec::new()) };
    let (Some(parent), true) = (parents[a], parents[a] == parents[b]) else { return Ok(Vec::new()) };
    let others: Vec<usize> = (0..parents.len()).filter(|&k| parents[k] == Some(parent) && k != a && k != b).collect();
    let [neck] = others[..] else { return Ok(Vec::new()) };
    let (rest_rot, moved, posed) = world_rotations(model, pose)?;
    let at = |j: usize| posed[j].w_axis.truncate();
    let head = subtree(parents, neck);
    let far =
        head.iter().map(|&k| at(k) - at(neck)).fold(Vec3::ZERO, |m, d| if d.length() > m.length() { d } else { m });
    let up = Quat::from_scaled_axis(pose.orientation) * Vec3::Y;
    let Some(axis) = far.try_normalize().or_else(|| up.try_normalize()) else { return Ok(Vec::new()) };
    Ok([-2i8, -1, 1, 2]
        .into_iter()
        .map(|twelfths| {
            let turn = Mat3::from_axis_angle(axis, f32::from(twelfths) * std::f32::consts::PI / 6.0);
            (LimbSwap::HeadTurn(twelfths), candidate_pose(pose, parents, &rest_rot, turned(&moved, &head, turn)))
        })
        .collect())
}

/// A candidate's world rotations relative to rest, one per joint, and which of them changed.
type ChangedRotations = (Vec<Mat3>, Vec<bool>);

/// `moved` with the world rotations of `joints` turned by `turn` (`T_k → S T_k`: the part they
/// move swung about an axis through the first of them), and which changed.
fn turned(moved: &[Mat3], joints: &[usize], turn: Mat3) -> ChangedRotations {
    let (mut t, mut changed) = (moved.to_vec(), vec![false; moved.len()]);
    for &k in joints {
        t[k] = turn * moved[k];
        changed[k] = true;
    }
    (t, changed)
}

/// The [`LimbSwap::Twist`] candidates of the arm whose first joint is `arm` (`at`: a joint's
/// position at the pose, `moved`: every joint's world rotation relative to rest), each with its
/// world rotations and which of them changed; none when the arm has no elbow or no length.
fn forearm_twists(
    parents: &[Option<usize>],
    arm: usize,
    at: &impl Fn(usize) -> Vec3,
    moved: &[Mat3],
) -> Vec<(LimbSwap, ChangedRotations)> {
    let n = parents.len();
    // The elbow: the child with the most joints below it (the first such, in joint order).
    let Some((below, elbow)) = (0..n)
        .filter(|&k| parents[k] == Some(arm))
        .map(|k| (subtree(parents, k), k))
        .max_by(|(a, ka), (b, kb)| a.len().cmp(&b.len()).then(kb.cmp(ka)))
    else {
        return Vec::new();
    };
    let axis = (at(elbow) - at(arm)).normalize_or_zero();
    if axis == Vec3::ZERO {
        return Vec::new();
    }
    (1..=3u8)
        .map(|quarter| {
            let turn = Mat3::from_axis_angle(axis, f32::from(quarter) * std::f32::consts::FRAC_PI_2);
            (LimbSwap::Twist(elbow, quarter), turned(moved, &below, turn))
        })
        .collect()
}

/// Each joint's rest world rotation `Q⁰`, its world rotation relative to rest at `pose`,
/// `T = Q Q⁰ᵀ`, and its world transform at `pose`.
pub(super) fn world_rotations(model: &SkinnedMesh, pose: &Pose) -> Result<(Vec<Mat3>, Vec<Mat3>, Vec<Mat4>)> {
    let rest = model.joint_transforms(&Pose::rest(model.joint_count()))?;
    let posed = model.joint_transforms(pose)?;
    let rest_rot: Vec<Mat3> = rest.iter().map(rotation).collect();
    let moved: Vec<Mat3> = posed.iter().zip(&rest_rot).map(|(g, q0)| rotation(g) * q0.transpose()).collect();
    Ok((rest_rot, moved, posed))
}

/// Joint `k`'s rotation offset `θ_k` for the world rotations relative to rest `t` (its parent's
/// included): `R(θ_k) = Q⁰_kᵀ T_pᵀ T_k Q⁰_k`.
pub(super) fn joint_rotation(parents: &[Option<usize>], rest_rot: &[Mat3], t: &[Mat3], k: usize) -> Vec3 {
    let parent = parents[k].map_or(Mat3::IDENTITY, |p| t[p]);
    axis_angle(rest_rot[k].transpose() * parent.transpose() * t[k] * rest_rot[k])
}

/// The rotation of a joint's world transform (its columns normalised: a uniform scale divided out).
fn rotation(g: &Mat4) -> Mat3 {
    let m = Mat3::from_mat4(*g);
    Mat3::from_cols(m.x_axis.normalize_or_zero(), m.y_axis.normalize_or_zero(), m.z_axis.normalize_or_zero())
}

/// `I − 2nnᵀ` for a unit `n`.
fn reflection(n: Vec3) -> Mat3 {
    Mat3::IDENTITY - 2.0 * Mat3::from_cols(n * n.x, n * n.y, n * n.z)
}

/// The rotation vector (axis × angle, angle in [0, π]) of a rotation matrix.
fn axis_angle(m: Mat3) -> Vec3 {
    let q = Quat::from_mat3(&m).normalize();
    let q = if q.w < 0.0 { -q } else { q };
    let (axis, angle) = q.to_axis_angle();
    axis * angle
}

/// `root` and every joint below it, in joint order.
fn subtree(parents: &[Option<usize>], root: usize) -> Vec<usize> {
    let mut inside = vec![false; parents.len()];
    inside[root] = true;
    let mut out = vec![root];
    for j in root + 1..parents.len() {
        if let Some(p) = parents[j] {
            if inside[p] {
                inside[j] = true;
                out.push(j);
            }
        }
    }
    // Joints listed before their parent (unusual orders) are found by repeating the sweep.
    loop {
        let mut grew = false;
        for j in 0..parents.len() {
            if let Some(p) = parents[j] {
                if inside[p] && !inside[j] {
                    inside[j] = true;
                    out.push(j);
                    grew = true;
                }
            }
        }
        if !grew {
            break;
        }
    }
    out.sort_unstable();
    out
}

/// The joints of the subtrees under `a` and `b` paired in joint order, when the two have the same
/// shape (each pair's parents paired too); `None` otherwise.
pub(super) fn matched_subtrees(parents: &[Option<usize>], a: usize, b: usize) -> Option<Vec<(usize, usize)>> {
    let (sa, sb) = (subtree(parents, a), subtree(parents, b));
    if sa.len() != sb.len() {
        return None;
    }
    let pairs: Vec<(usize, usize)> = sa.into_iter().zip(sb).collect();
    for &(x, y) in &pairs[1..] {
        let (px, py) = (parents[x]?, parents[y]?);
        if !pairs.contains(&(px, py)) {
            return None;
        }
    }
    Some(pairs)
}
