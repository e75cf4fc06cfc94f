//! `motionctl polar ...`: digitize a contour into a step-event stream file, dump a stream, and
//! optimise the machine pole. Lengths in inches, angles in radians (the thesis's listing units).
//! The lead wires [`PolarCmd`] into the main command line.
//!
//! Parts: `args` (the command line), `board_cmds` (the subcommands that drive a board); the
//! offline subcommands run here.

mod args;
mod board_cmds;

pub use args::{parse_contour, parse_size, FeedAtArg, PolarCmd, ResArgs, DEFAULT_TICK_HZ};
use board_cmds::{run_copy, run_stream};

use super::contour::{Contour, Scaled};
use super::digitize::{digitize, DigitizeError, FeedAt, Setup};
use super::pole::{self, Constraints, HookeJeeves, Pole, MM2_PER_IN2};
use super::work_area::WorkArea;
use crate::units::Units;
use anyhow::{bail, Context};
use motion::polar::stream::BlockEncoder;

/// The work area of `--machine FILE`, or Fahim's machine.
fn work_area(machine: Option<&std::path::Path>) -> anyhow::Result<WorkArea> {
    machine.map_or(Ok(WorkArea::FAHIM_1983), WorkArea::from_file)
}

/// For a contour that leaves the work area: a machine pole (from the pole optimiser, checked by
/// digitizing with it) that keeps it inside, as the flags to give, or why there is none.
fn suggest_pole(contour: &dyn Contour, setup: &Setup, units: Units) -> String {
    // The contour must stay a tool radius inside for the tool centre to be inside.
    let opt = setup.area.inset(setup.tool_radius_in).and_then(|inner| {
        pole::optimise(contour, &setup.res, Constraints::WorkArea(inner), &HookeJeeves::default())
    });
    let fits = opt.filter(|o| {
        let (pole_r_in, pole_angle_rad) = o.pole.digitizer_pole();
        digitize(contour, &Setup { pole_r_in, pole_angle_rad, ..*setup }).is_ok()
    });
    match fits {
        Some(o) => format!(
            "a pole that fits: --pole-c {:.4} --pole-beta {:.4} (C {:.2} mm; least area error \
             F1 {:.4})",
            units.from_in(o.pole.c_in),
            o.pole.beta_rad,
            o.pole.c_in * 25.4,
            o.f1.f1
        ),
        None => "no machine pole fits it in this work area: the contour (with the tool) is too \
                 large for it"
            .to_string(),
    }
}

/// Runs one `polar` subcommand, printing to stdout.
pub fn run(cmd: PolarCmd) -> anyhow::Result<()> {
    match cmd {
        PolarCmd::Digitize {
            contour,
            pole_c,
            pole_beta,
            tool_radius,
            vt,
            units,
            feed_at,
            res,
            tick_hz,
            no_cap,
            machine,
            out,
            plot,
            json,
        } => {
            let c = Scaled::new(parse_contour(&contour)?, units.to_in(1.0));
            let area = work_area(machine.as_deref())?;
            let (pole_r_in, pole_angle_rad) =
                Pole { c_in: units.to_in(pole_c), beta_rad: pole_beta }.digitizer_pole();
            let res = res.res_in(units)?;
            let setup = Setup {
                pole_r_in,
                pole_angle_rad,
                tool_radius_in: units.to_in(tool_radius),
                vt_in_per_s: units.to_in(vt),
                feed_at: feed_at.into(),
                res,
                tick_hz,
                cap_speed: !no_cap,
                area,
            };
            let d = match digitize(&c, &setup) {
                Err(e @ DigitizeError::OutsideWorkArea { .. }) => {
                    bail!("{e}; {}", suggest_pole(&c, &setup, units))
                }
                r => r?,
            };
            let ticks: u64 = d.events.iter().map(|e| e.dt_ticks as u64).sum();
            let radial = d.events.iter().filter(|e| e.axis == 1).count();
            // Where the machine starts: the tool centre's (r, theta) about the machine pole,
            // on the digitizer's grids.
            let start_r_in = d.start_r_steps as f64 * setup.res.dr_in;
            let start_theta_deg = d.theta0_rad.to_degrees();
            let duration_s = ticks as f64 / tick_hz as f64;
            // The cut's time from its length: the stream must last this (to a tick per event).
            let expected_s = d.feed_length_in / d.vt_in_per_s;
            let feed_name = match setup.feed_at {
                FeedAt::Contact => "contact",
                FeedAt::Centre => "centre",
            };
            let u = units.name();
            let len = |v_in: f64| units.from_in(v_in);
            if json {
                let mut v = serde_json::json!({
                    "units": u,
                    "events": d.events.len(),
                    "radial_events": radial,
                    "angular_events": d.events.len() - radial,
                    "feed_at": feed_name,
                    "duration_s": duration_s,
                    "expected_s": expected_s,
                    "start_theta_deg": start_theta_deg,
                    "warnings": d.warnings.len(),
                });
                for (key, v_in) in [
                    ("path", d.length_in),
                    ("contact_path", d.contact_length_in),
                    ("start_r", start_r_in),
                    ("min_radius_of_curvature", d.min_rho_in),
                ] {
                    v[format!("{key}_{u}")] = serde_json::json!(len(v_in));
                }
                v[format!("vt_{u}_per_s")] = serde_json::json!(len(d.vt_in_per_s));
                crate::outln!("{v}");
            } else {
                crate::outln!(
                    "start      r {:.4} {u}, theta {start_theta_deg:.3} deg (tool centre about the \
                     machine pole)",
                    len(start_r_in)
                );
                crate::outln!(
                    "{} events ({radial} radial, {} angular), min radius of curvature {:.4} {u}",
                    d.events.len(),
                    d.events.len() - radial,
                    len(d.min_rho_in)
                );
                crate::outln!(
                    "path       contact {:.4} {u}, tool centre {:.4} {u}; Vt {:.4} {u}/s held at \
                     the {}",
                    len(d.contact_length_in),
                    len(d.length_in),
                    len(d.vt_in_per_s),
                    if setup.feed_at == FeedAt::Contact { "contact point" } else { "tool centre" }
                );
                crate::outln!(
                    "time       {duration_s:.4} s ({:.4} {u} / {:.4} {u}/s = {expected_s:.4} s)",
                    len(d.feed_length_in),
                    len(d.vt_in_per_s)
                );
            }
            for w in &d.warnings {
                eprintln!("motionctl: warning: {w}");
            }
            if let Some(p) = &plot {
                let u = units.name();
                let title = format!(
                    "polar digitize {contour} ({u}): tool radius {tool_radius} {u}, Vt {vt} {u}/s, \
                     pole C {pole_c} {u} at beta {pole_beta} rad"
                );
                super::figure::digitized_figure(&c, &setup, &d, &title).save(p)?;
            }
            if let Some(path) = out {
                let mut bytes = Vec::new();
                let mut enc = BlockEncoder::new();
                for &e in &d.events {
                    enc.push(e, &mut |b: &[u8]| bytes.extend_from_slice(b))
                        .map_err(|e| anyhow::anyhow!("encoding: {e:?}"))?;
                }
                enc.finish(&mut |b: &[u8]| bytes.extend_from_slice(b));
                std::fs::write(&path, &bytes)
                    .with_context(|| format!("writing {}", path.display()))?;
                eprintln!(
                    "motionctl: wrote {} ({} bytes, {} blocks)",
                    path.display(),
                    bytes.len(),
                    enc.blocks()
                );
            }
            Ok(())
        }
        PolarCmd::Dump { file, tick_hz } => {
            let bytes =
                std::fs::read(&file).with_context(|| format!("reading {}", file.display()))?;
            let mut text = String::new();
            let r = super::dump::dump(&bytes, tick_hz, &mut text);
            crate::out!("{text}");
            // The dump's own error line says where and what (the listing may have gone to a
            // closed pipe or a file): the same words on stderr.
            r.map(|_| ()).map_err(|e| {
                let line = text.lines().rev().find_map(|l| l.strip_prefix("error: "));
                let why = line.map_or_else(|| format!("{e:?}"), str::to_string);
                anyhow::anyhow!("{}: {why}", file.display())
            })
        }
        PolarCmd::Run { file, link, speed, size, json } => {
            run_stream(&file, &link, speed, size, json)
        }
        PolarCmd::Copy { link, size, teach, template, seconds, json } => {
            run_copy(&link, size, teach.as_deref(), template.as_deref(), seconds, json)
        }
        PolarCmd::Pole { contour, res, box_only, machine, json } => {
            let c = parse_contour(&contour)?;
            let res = res.res()?;
            let work = work_area(machine.as_deref())?;
            let constraints = match box_only {
                Some(half_in) => Constraints::Box { centre: [0.0, 0.0], half_in },
                None => Constraints::WorkArea(work),
            };
            let Some(o) = pole::optimise(c.as_ref(), &res, constraints, &HookeJeeves::default())
            else {
                bail!("no feasible pole found for {contour}");
            };
            let area = pole::area_error_in2(c.as_ref(), o.pole.xy(), &res, 4);
            let fits = pole::check(c.as_ref(), o.pole.xy(), &work);
            if json {
                let v = serde_json::json!({
                    "pole_c_in": o.pole.c_in,
                    "pole_c_mm": o.pole.c_in * 25.4,
                    "pole_beta_rad": o.pole.beta_rad,
                    "f1": o.f1.f1,
                    "f_dif": o.f1.f_dif,
                    "f_sum": o.f1.f_sum,
                    "evaluations": o.evals,
                    "area_error_in2": area,
                    "area_error_mm2": area * MM2_PER_IN2,
                    "in_work_area": fits.is_ok(),
                });
                crate::outln!("{v}");
                return Ok(());
            }
            crate::outln!(
                "pole C = {:.4} in ({:.3} cm), beta = {:.4} rad; F1 = {:.5} (F_dif {:.1}, F_sum {:.1}, {} evaluations)",
                o.pole.c_in,
                o.pole.c_in * super::CM_PER_IN,
                o.pole.beta_rad,
                o.f1.f1,
                o.f1.f_dif,
                o.f1.f_sum,
                o.evals
            );
            crate::outln!(
                "area error {:.6} in^2 = {:.3} mm^2; constraints: {:?}",
                area,
                area * MM2_PER_IN2,
                fits
            );
            crate::outln!(
                "digitize with --pole-c {:.4} --pole-beta {:.4} (work area {work})",
                o.pole.c_in,
                o.pole.beta_rad
            );
            Ok(())
        }
    }
}
