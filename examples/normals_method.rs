//! A method added from outside rsl: a normals view (each vertex's world normal as a colour,
//! `0.5 + 0.5·n`), made by implementing `rsl_engine::Method` (whole frames) and
//! `rsl_engine::compose::ObjectDrawing` (single objects) and registering it. The program is
//! then the `rsl` command line with one more method: `normals` appears in
//! `rsl render --method`, the bench's `--sweep method=`, the viewer's drawing drop-down, and
//! scene files may give it to single objects (`method = "normals"`, drawn so by `auto`),
//! none of which was edited for it.
//!
//! ```text
//! cargo run --release --example normals_method -- render data/scenes/default.toml --method normals --out normals.png
//! cargo run --release --example normals_method -- view data/scenes/default.toml --drawing normals
//! ```

use anyhow::Result;
use clap::Parser;
use glam::Vec3;
use rsl_engine::compose::{FrameContext, ObjectDrawing, Part};
use rsl_engine::method::{Frame, Method, Request};
use rsl_engine::registry::{Capabilities, ErrorModel, ImageKind, Incremental};
use rsl_engine::scene::Brdf;
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, Layers, MethodOptions, Registration, Timings};
use rsl_shade::FrameStats;

/// Each vertex's world normal as a colour.
struct Normals;

impl Method for Normals {
    fn describe(&self) -> String {
        "world normals as colours (an example method)".into()
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        let state = scene.at(request.time);
        let mut timings = Timings::default();
        let radiance = timings.time("shade", || {
            (0..scene.objects.len())
                .map(|i| {
                    let pose = rsl_shade::Pose::new(&state.objects[i]);
                    engine.mesh(i).normals.iter().map(|n| Vec3::splat(0.5) + 0.5 * pose.normal(*n)).collect()
                })
                .collect()
        });
        Frame::of_vertices(engine, scene, state, radiance, request.image, timings)
    }
}

impl ObjectDrawing for Normals {
    fn describe(&self, _: &Brdf) -> String {
        "its world normals as colours".into()
    }

    fn shade<'f>(
        &mut self,
        ctx: &FrameContext<'f>,
        which: &[bool],
        _: &mut FrameStats,
    ) -> Result<Vec<Option<Part<'f>>>> {
        Ok((0..which.len())
            .map(|i| {
                which[i].then(|| Part::vertices(ctx.normals[i].iter().map(|n| Vec3::splat(0.5) + 0.5 * *n).collect()))
            })
            .collect())
    }
}

fn normals(_: &Engine, _: &MethodOptions) -> Result<Box<dyn Method>> {
    Ok(Box::new(Normals))
}

fn main() -> std::process::ExitCode {
    let registered = rsl_engine::registry::register(Registration {
        name: "normals",
        aliases: &[],
        summary: "world normals as colours (an example method registered by a program)",
        when: "checking a mesh's normals and the registry's front ends",
        capabilities: Capabilities {
            image: ImageKind::Vertices,
            cpu: true,
            gpu: false,
            layers: Layers { rsl: false },
            monte_carlo: false,
            anisotropic: true,
            per_object: true,
            oracles: false,
            interactive: true,
            incremental: Incremental::Frames,
            error: ErrorModel::Unbounded,
        },
        constructor: normals,
        drawing: Some(|| Box::new(Normals)),
    });
    if let Err(e) = registered {
        eprintln!("error: {e:#}");
        return std::process::ExitCode::FAILURE;
    }
    match rsl::cli::run(rsl::cli::Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
