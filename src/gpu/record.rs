//! Recording the stages of one submission: [`StagePasses`] records each dispatch into the command
//! encoder and into a [`Recording`] that names the buffers it touches (like vello's `Recording`),
//! kept for the last submission so that tests can check the data flow between stages.

use super::bindings::{entry_bindings, StageGroups};
use super::pipelines::Pipelines;
use super::stages::{Grid, Stage};
use super::{GpuContext, StageTimer};
use crate::{Error, Result};

/// How much work a dispatch runs.
pub(crate) enum Work<'a> {
    /// This many work items; the stage's [`Grid`] turns them into workgroups, as a 2D grid when
    /// needed ([`GpuContext::dispatch_1d`]).
    Items(u32),
    /// The grid in this buffer (named as in the frame's buffer table), written by an earlier stage
    /// of the same submission.
    Indirect(&'static str, &'a wgpu::Buffer),
}

/// The workgroups of a recorded dispatch.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Workgroups {
    /// This grid.
    Direct([u32; 3]),
    /// The grid in the named buffer.
    Indirect(&'static str),
}

/// One command of a recorded submission, in submission order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Command {
    /// The host wrote (part of) the buffer before the submission (`queue.write_buffer`).
    Upload(&'static str),
    /// The buffer holds data the host uploaded in an earlier call, which the submission relies on
    /// (the topology, the targets of a step).
    Resident(&'static str),
    /// The encoder cleared (part of) the buffer.
    Clear(&'static str),
    /// A stage ran: the buffers its entry point reads and writes (reflected), and its grid.
    Dispatch { stage: &'static str, reads: Vec<&'static str>, writes: Vec<&'static str>, workgroups: Workgroups },
    /// The encoder copied (part of) `from` to `to`.
    Copy { from: &'static str, to: &'static str },
}

/// What the last submission did, buffer by buffer.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Recording {
    /// The submission's label.
    pub label: &'static str,
    /// Its commands, in order.
    pub commands: Vec<Command>,
}

#[cfg_attr(not(test), allow(dead_code))] // read by tests
impl Recording {
    /// An empty recording of submission `label`.
    pub fn new(label: &'static str) -> Recording {
        Recording { label, commands: Vec::new() }
    }

    /// The stages dispatched, in order.
    pub fn stages(&self) -> Vec<&'static str> {
        self.commands
            .iter()
            .filter_map(|c| match c {
                Command::Dispatch { stage, .. } => Some(*stage),
                _ => None,
            })
            .collect()
    }

    /// Checks that every buffer a stage reads (its indirect arguments included) was uploaded,
    /// resident, cleared or written by an earlier stage; returns the first violation.
    pub fn check_reads_follow_writes(&self) -> std::result::Result<(), String> {
        let mut defined: Vec<&'static str> = Vec::new();
        for command in &self.commands {
            match command {
                Command::Upload(name) | Command::Resident(name) | Command::Clear(name) => defined.push(name),
                Command::Copy { to, .. } => defined.push(to),
                Command::Dispatch { stage, reads, writes, workgroups } => {
                    let indirect = match workgroups {
                        Workgroups::Indirect(name) => Some(*name),
                        Workgroups::Direct(_) => None,
                    };
                    for name in reads.iter().copied().chain(indirect) {
                        if !defined.contains(&name) {
                            return Err(format!(
                                "`{}`: stage `{stage}` reads `{name}`, which nothing uploaded, cleared or wrote before",
                                self.label
                            ));
                        }
                    }
                    defined.extend(writes.iter().copied());
                }
            }
        }
        Ok(())
    }
}

/// Records the stages of one submission: all in one compute pass (wgpu orders the dispatches), or,
/// when profiling, each in a pass of its own with timestamps around it.
#[allow(clippy::large_enum_variant)] // one per submission, on the stack: boxing would allocate
enum Passes<'e> {
    Shared(wgpu::ComputePass<'e>),
    Timed { encoder: &'e mut wgpu::CommandEncoder, timer: &'e mut StageTimer },
}

/// The passes of one submission and its [`Recording`].
pub(crate) struct StagePasses<'e> {
    passes: Passes<'e>,
    recording: &'e mut Recording,
}

impl<'e> StagePasses<'e> {
    /// Records into `encoder` (timed by `timer` when profiling) and `recording`.
    pub fn new(
        encoder: &'e mut wgpu::CommandEncoder,
        timer: Option<&'e mut StageTimer>,
        recording: &'e mut Recording,
    ) -> StagePasses<'e> {
        let passes =
            match timer {
                Some(timer) => Passes::Timed { encoder, timer },
                None => Passes::Shared(encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("diffsil"),
                    timestamp_writes: None,
                })),
            };
        StagePasses { passes, recording }
    }

    /// Records `stage` with its bind groups `groups` over `work`.
    pub fn run(
        &mut self,
        ctx: &GpuContext,
        pipelines: &Pipelines,
        stage: Stage,
        groups: Option<&StageGroups>,
        work: Work<'_>,
    ) -> Result<()> {
        let info = stage.info();
        let groups =
            groups.ok_or_else(|| Error::Gpu(format!("stage `{}`: its bind groups were not made", info.name)))?;
        let [x, y, z] = super::workgroup_size(info.shader, info.entry_point).ok_or_else(|| {
            Error::Gpu(format!("stage `{}`: no reflected workgroup size for `{}`", info.name, info.shader))
        })?;
        let bindings = entry_bindings(info.shader, info.entry_point)?;
        let pipeline = pipelines.get(stage);
        let record = |pass: &mut wgpu::ComputePass<'_>| -> Result<Workgroups> {
            pass.set_pipeline(pipeline);
            for (index, group) in groups {
                pass.set_bind_group(*index, group, &[]);
            }
            Ok(match work {
                Work::Items(items) => {
                    let per_workgroup = match info.grid {
                        Grid::PerInvocation => x * y * z,
                        Grid::PerWorkgroup => 1,
                        Grid::ItemsPerWorkgroup(k) => k,
                    };
                    Workgroups::Direct(ctx.dispatch_1d(pass, items, per_workgroup)?)
                }
                Work::Indirect(name, arguments) => {
                    pass.dispatch_workgroups_indirect(arguments, 0);
                    Workgroups::Indirect(name)
                }
            })
        };
        let workgroups = match &mut self.passes {
            Passes::Shared(pass) => record(pass)?,
            Passes::Timed { encoder, timer } => {
                let timestamp_writes = timer.writes(info.name);
                record(
                    &mut encoder
                        .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(info.name), timestamp_writes }),
                )?
            }
        };
        self.recording.commands.push(Command::Dispatch {
            stage: info.name,
            reads: bindings.iter().filter(|b| b.reads).map(|b| b.name).collect(),
            writes: bindings.iter().filter(|b| b.writes).map(|b| b.name).collect(),
            workgroups,
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::engine::ViewInput;
    use crate::gpu::backend::{ForwardMode, GpuBackend};
    use crate::gpu::bindings::{bind_stage, BufferTable};
    use crate::gpu::GpuOptions;
    use crate::mirror::{RasterParams, ScreenVertex};
    use crate::scene::mesh::Topology;

    /// A context, or `None` (skipping) when there is no adapter and `DIFFSIL_REQUIRE_GPU` is not 1.
    fn context(test: &str) -> Option<GpuContext> {
        match GpuContext::new(&GpuOptions::from_env()) {
            Ok(ctx) => Some(ctx),
            Err(Error::NoAdapter(e)) if std::env::var("DIFFSIL_REQUIRE_GPU").map_or(true, |v| v.trim() != "1") => {
                eprintln!("SKIPPED (no GPU adapter): {test}: {e}");
                None
            }
            Err(e) => panic!("{test}: {e}"),
        }
    }

    /// Two overlapping triangles sharing a vertex, in two views of different sizes.
    fn scene() -> (Arc<Topology>, Vec<RasterParams>, Vec<Vec<ScreenVertex>>) {
        let topology = Arc::new(Topology::new(5, vec![[0, 1, 2], [2, 3, 4]]).unwrap());
        let params =
            vec![RasterParams::new(24, 20, 2, 1.0, 0.0).unwrap(), RasterParams::new(17, 9, 3, 1.0, 0.0).unwrap()];
        let points = [[2.5, 3.0], [20.0, 4.5], [9.0, 17.0], [1.0, 12.0], [15.5, 16.0]];
        let screen: Vec<ScreenVertex> =
            points.iter().map(|&[x, y]| ScreenVertex { position: [x, y], valid: 1, pad: 0 }).collect();
        let half: Vec<ScreenVertex> = screen
            .iter()
            .map(|v| ScreenVertex { position: [v.position[0] * 0.6, v.position[1] * 0.4], ..*v })
            .collect();
        (topology, params, vec![screen, half])
    }

    #[test]
    fn stages_read_only_what_was_uploaded_cleared_or_written_before() {
        let Some(ctx) = context("stages_read_only_what_was_uploaded_cleared_or_written_before") else { return };
        let indirect = ctx.supports_indirect_dispatch();
        let mut backend = GpuBackend::new(ctx).unwrap();
        let (topology, params, screens) = scene();
        let input = ViewInput::Screen(&screens);

        let out = backend.forward(&topology, &params, input, &[], ForwardMode::Images).unwrap();
        let forward = backend.last_recording().clone();
        assert_eq!(forward.stages(), ["snap", "bin_count", "scan", "bin_fill", "coverage", "resolve", "edges"]);
        forward.check_reads_follow_writes().unwrap();

        let d_images: Vec<Vec<f32>> = params.iter().map(|p| vec![1.0; p.pixel_count()]).collect();
        let refs: Vec<&[f32]> = d_images.iter().map(|d| d.as_slice()).collect();
        backend.backward(out.frame, &topology, &params, input, &[], Some(&refs)).unwrap();
        let backward = backend.last_recording().clone();
        assert_eq!(backward.stages(), ["edge_grad", "edge_sum", "gather"]);
        backward.check_reads_follow_writes().unwrap();

        let targets: Vec<Vec<f32>> = params.iter().map(|p| vec![0.5; p.pixel_count()]).collect();
        let refs: Vec<&[f32]> = targets.iter().map(|t| t.as_slice()).collect();
        for id in [1, 1] {
            backend.forward(&topology, &params, input, &[], ForwardMode::Step { ids: &[id], targets: &refs }).unwrap();
            let step = backend.last_recording().clone();
            let mut stages = vec!["snap", "bin_count", "scan", "bin_fill", "coverage", "resolve", "edges", "loss"];
            if indirect {
                stages.extend(["edge_grad_args", "edge_grad", "edge_sum", "gather"]);
            }
            assert_eq!(step.stages(), stages);
            step.check_reads_follow_writes().unwrap();
        }
    }

    #[test]
    fn a_3d_forward_projects_before_it_reads_the_screen_vertices() {
        let Some(ctx) = context("a_3d_forward_projects_before_it_reads_the_screen_vertices") else { return };
        let mut backend = GpuBackend::new(ctx).unwrap();
        let (topology, params, _) = scene();
        let positions: Vec<glam::Vec3> =
            [[-1.0, -1.0, 0.0], [1.0, -0.8, 0.2], [0.1, 1.0, 0.0], [-0.9, 0.6, 0.3], [0.8, 0.9, -0.2]]
                .map(glam::Vec3::from)
                .to_vec();
        let cameras: Vec<crate::mirror::ViewParams> = params
            .iter()
            .map(|p| crate::mirror::ViewParams {
                row0: [1.0, 0.0, 0.0, 0.0],
                row1: [0.0, 1.0, 0.0, 0.0],
                row2: [0.0, 0.0, 1.0, -5.0],
                centre: [p.width as f32 / 2.0, p.height as f32 / 2.0],
                scale: [20.0; 2],
                perspective: 1,
                near: 0.1,
                far: 100.0,
                width: p.width,
                height: p.height,
                pad0: 0,
                pad1: 0,
                pad2: 0,
            })
            .collect();
        let input = ViewInput::World { positions: &positions, cameras: &cameras };
        backend.forward(&topology, &params, input, &[], ForwardMode::Images).unwrap();
        let forward = backend.last_recording();
        assert_eq!(forward.stages(), ["project", "bin_count", "scan", "bin_fill", "coverage", "resolve", "edges"]);
        forward.check_reads_follow_writes().unwrap();
    }

    /// A batch (two instances, two views each, each view reading its instance's positions) is one
    /// submission per forward, backward or fused step, and reads only what it wrote.
    #[test]
    fn a_batch_submission_reads_only_what_was_uploaded_cleared_or_written_before() {
        let Some(ctx) = context("a_batch_submission_reads_only_what_was_uploaded_cleared_or_written_before") else {
            return;
        };
        let indirect = ctx.supports_indirect_dispatch();
        let mut backend = GpuBackend::new(ctx).unwrap();
        let (topology, two, _) = scene();
        let params = [two.clone(), two].concat();
        let first = [[-1.0, -1.0, 0.0], [1.0, -0.8, 0.2], [0.1, 1.0, 0.0], [-0.9, 0.6, 0.3], [0.8, 0.9, -0.2]];
        let positions: Vec<glam::Vec3> = first
            .iter()
            .chain(first.iter())
            .enumerate()
            .map(|(i, &p)| glam::Vec3::from(p) * (1.0 - 0.05 * i as f32))
            .collect();
        let cameras: Vec<crate::mirror::ViewParams> = params
            .iter()
            .map(|p| {
                crate::Camera::perspective(glam::Vec3::new(0.0, 0.0, 5.0), glam::Vec3::ZERO, 0.8, p.width, p.height)
                    .params()
            })
            .collect();
        let offsets = [0, 0, 5, 5];
        let input = ViewInput::World { positions: &positions, cameras: &cameras };
        let out = backend.forward(&topology, &params, input, &offsets, ForwardMode::Images).unwrap();
        let forward = backend.last_recording().clone();
        assert_eq!(forward.stages(), ["project", "bin_count", "scan", "bin_fill", "coverage", "resolve", "edges"]);
        forward.check_reads_follow_writes().unwrap();
        assert_ne!(out.images[0], out.images[2], "both instances rendered the same positions");
        let buffers = backend.frame.as_ref().map(|f| f.positions.clone()).unwrap();

        let d_images: Vec<Vec<f32>> = params.iter().map(|p| vec![1.0; p.pixel_count()]).collect();
        let refs: Vec<&[f32]> = d_images.iter().map(|d| d.as_slice()).collect();
        backend.backward(out.frame, &topology, &params, input, &offsets, Some(&refs)).unwrap();
        let backward = backend.last_recording().clone();
        assert_eq!(backward.stages(), ["edge_grad", "edge_sum", "gather"]);
        backward.check_reads_follow_writes().unwrap();

        let targets: Vec<Vec<f32>> = params.iter().map(|p| vec![0.5; p.pixel_count()]).collect();
        let refs: Vec<&[f32]> = targets.iter().map(|t| t.as_slice()).collect();
        for _ in 0..2 {
            backend
                .forward(&topology, &params, input, &offsets, ForwardMode::Step { ids: &[7, 8], targets: &refs })
                .unwrap();
            let step = backend.last_recording().clone();
            let mut stages = vec!["project", "bin_count", "scan", "bin_fill", "coverage", "resolve", "edges", "loss"];
            if indirect {
                stages.extend(["edge_grad_args", "edge_grad", "edge_sum", "gather"]);
            }
            assert_eq!(step.stages(), stages);
            step.check_reads_follow_writes().unwrap();
        }
        // The buffers of a batch shape are made once and reused; another instance count is another
        // shape.
        assert!(backend.frame.as_ref().is_some_and(|f| f.positions == buffers), "the batch's buffers were made again");
        let one = ViewInput::World { positions: &positions[..5], cameras: &cameras[..2] };
        backend.forward(&topology, &params[..2], one, &[], ForwardMode::Images).unwrap();
        assert!(backend.frame.as_ref().is_some_and(|f| f.positions != buffers));
    }

    #[test]
    fn the_check_finds_a_read_before_any_write() {
        let recording = Recording {
            label: "test",
            commands: vec![
                Command::Upload("frame"),
                Command::Dispatch {
                    stage: "resolve",
                    reads: vec!["frame", "masks"],
                    writes: vec!["image"],
                    workgroups: Workgroups::Direct([1, 1, 1]),
                },
            ],
        };
        let error = recording.check_reads_follow_writes().unwrap_err();
        assert!(error.contains("resolve") && error.contains("masks"), "{error}");
    }

    #[test]
    fn a_missing_buffer_names_the_stage_and_the_variable() {
        let Some(ctx) = context("a_missing_buffer_names_the_stage_and_the_variable") else { return };
        let pipelines = Pipelines::new(&ctx).unwrap();
        let frame = ctx.storage_buffer("frame", 64).unwrap();
        let table = BufferTable::default().with("frame", &frame);
        let Err(Error::Gpu(message)) = bind_stage(&ctx, pipelines.get(Stage::Snap), Stage::Snap, &table) else {
            panic!("binding `snap` without its buffers succeeded");
        };
        assert!(message.contains("`snap`") && message.contains("`screen`"), "{message}");
    }
}
