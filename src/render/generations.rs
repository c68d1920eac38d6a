//! `cobalt render --pipeline generations`: every generation of rays scheduled on its own over
//! the devices ([`raytrace::scheduled::ScheduledTracer`]), the rays made and shaded on the host.

use raytrace::cost_image::cost_image;
use raytrace::film::ToneMap;
use raytrace::scheduled::{FailAfter, ScheduledTracer, Settings, build_devices};
use raytrace::shade::{RenderOptions, render};
use raytrace::{Bvh, Scene};

use super::header::Header;
use super::rendered::Rendered;
use super::report::Report;
use crate::args::Devices;
use crate::error::CliError;

/// Renders `options` through a scheduled tracer over `devices`; a generation whose every
/// device failed is an error unless `host_fallback` let the host trace it.
pub fn render_generations(
    scene: &Scene,
    bvh: &Bvh,
    options: &RenderOptions,
    (devices, faults): (&Devices, &[FailAfter]),
    settings: Settings,
    host_fallback: bool,
    header: Header,
) -> Result<Rendered<Report>, CliError> {
    let mut tracer =
        ScheduledTracer::new(bvh, build_devices(bvh, devices.specs(), faults)?, settings)?;
    let rendering = render(scene, &mut tracer, options);
    if !host_fallback && tracer.stats().iter().any(|g| g.host_fallback) {
        let failures: Vec<_> = tracer
            .stats()
            .iter()
            .flat_map(|g| g.failures.iter().cloned())
            .collect();
        return Err(CliError::devices_failed(devices.as_str(), &failures));
    }
    // Encoded before anything is written, so a failure leaves no partial set of outputs.
    let image = rendering.film.png(ToneMap::Srgb)?;
    let cost_image = match &rendering.primary_counts {
        Some(counts) => {
            let (w, h) = (options.width, options.height);
            Some(cost_image(counts, w, h).png(ToneMap::Display)?)
        }
        None => None,
    };
    let report = Report::new(header, devices, settings, &tracer, &rendering);
    Ok(Rendered {
        image,
        cost_image,
        report,
    })
}
