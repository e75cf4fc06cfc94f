//! What a milling run did, in the job's units (N, mm, mm/min, rpm, ms, s): printed as text
//! lines or as one JSON object (keys carry their unit: `fnom_n`, `settle_ms`, ...).

use super::job::MillingJob;
use super::steady;
use motion::scenario::ScenarioReport;
use serde_json::{json, Map, Value};

/// The band the settling is judged by, as a fraction of Fnom, and the window after the depth
/// step (the scenario's).
pub const BAND: f64 = 0.10;
pub const WINDOW_MS: f64 = 400.0;
/// Settled: no force outside the band in the last part of the window.
const SETTLED_BEFORE_MS: f64 = 350.0;

/// A fault code's name.
pub fn fault_name(code: u8) -> String {
    motion::protocol::FaultCode::TABLE
        .iter()
        .find(|(c, _, _)| *c == code)
        .map_or_else(|| format!("code {code}"), |(_, name, _)| name.to_string())
}

/// The job's own numbers as summary lines.
pub fn job_lines(job: &MillingJob) -> Vec<String> {
    vec![
        format!(
            "job        {}: Fnom {:.0} N (contact {:.0} N, trip {:.0} N), strategy {}",
            job.name, job.fnom_n, job.contact_n, job.trip_n, job.strategy
        ),
        format!(
            "spindle    {} rpm (hold below {} rpm), {} teeth, cutter {} mm ({:.1} m/min), {} \
             mm/tooth: programmed feed {:.1} mm/min; tooth period {:.2} ms",
            job.spindle_rpm,
            job.min_spindle_rpm,
            job.teeth,
            job.cutter_diameter_mm,
            job.cutting_speed_m_min(),
            job.feed_per_tooth_mm,
            job.programmed_feed_mm_min(),
            job.tooth_period_s() * 1e3
        ),
        format!(
            "cut        Kc {} N/mm^2, axial depth {} -> {} mm at {} mm into the cut",
            job.kc_n_per_mm2, job.b_before_mm, job.b_after_mm, job.step_at_mm
        ),
    ]
}

/// The job's own numbers and the plant's steady states as JSON fields.
pub fn job_json(job: &MillingJob) -> Map<String, Value> {
    let (before, at_step, after) = steady::predict(job);
    let v = json!({
        "name": job.name,
        "fnom_n": job.fnom_n,
        "contact_n": job.contact_n,
        "trip_n": job.trip_n,
        "strategy": job.strategy,
        "spindle_rpm": job.spindle_rpm,
        "min_spindle_rpm": job.min_spindle_rpm,
        "teeth": job.teeth,
        "cutter_diameter_mm": job.cutter_diameter_mm,
        "cutting_speed_m_min": job.cutting_speed_m_min(),
        "feed_per_tooth_mm": job.feed_per_tooth_mm,
        "programmed_feed_mm_min": job.programmed_feed_mm_min(),
        "tooth_period_ms": job.tooth_period_s() * 1e3,
        "kc_n_per_mm2": job.kc_n_per_mm2,
        "b_before_mm": job.b_before_mm,
        "b_after_mm": job.b_after_mm,
        "step_at_mm": job.step_at_mm,
        "predicted_force_before_n": before.force_n,
        "predicted_feed_before_mm_min": before.feed_mm_min,
        "predicted_force_at_step_n": at_step,
        "predicted_force_after_n": after.force_n,
        "predicted_feed_after_mm_min": after.feed_mm_min,
    });
    match v {
        Value::Object(m) => m,
        _ => Map::new(),
    }
}

/// The simulation's figures in the job's units.
#[derive(Clone, Debug, PartialEq)]
pub struct SimSummary {
    pub force_before_step_n: f64,
    pub feed_before_step_mm_min: Option<f64>,
    pub contact_peak_n: f64,
    pub peak_force_n: f64,
    /// From the depth step to the last force outside Fnom +-10 % in the 400 ms window.
    pub settle_ms: Option<f64>,
    pub settled: bool,
    pub overshoot_below_fnom_n: Option<f64>,
    pub late_ripple_n: Option<f64>,
    pub feed_after_step_mm_min: Option<f64>,
    pub fault: Option<String>,
    pub fault_position_mm: Option<f64>,
    pub stop_distance_mm: Option<f64>,
    pub machine_s: f64,
    pub control_updates: i64,
    pub lost_steps: i64,
}

impl SimSummary {
    pub fn new(r: &ScenarioReport, tick_hz: u32) -> Self {
        let fig = |k: &str| r.figure(k);
        let n = |k: &str| fig(k).map(|v| v as f64 / 1e3);
        let settle_ms = fig("settle_us").map(|us| us as f64 / 1e3);
        SimSummary {
            force_before_step_n: n("force_before_step_mn").unwrap_or(0.0),
            feed_before_step_mm_min: fig("feed_before_step_um_s").map(|v| v as f64 * 0.06),
            contact_peak_n: n("contact_peak_mn").unwrap_or(0.0),
            peak_force_n: n("peak_force_mn").unwrap_or(0.0),
            settle_ms,
            settled: settle_ms.is_some_and(|t| t < SETTLED_BEFORE_MS) && r.fault == 0,
            overshoot_below_fnom_n: n("overshoot_below_fnom_mn"),
            late_ripple_n: n("late_ripple_mn"),
            feed_after_step_mm_min: fig("feed_after_step_um_s").map(|v| v as f64 * 0.06),
            fault: (r.fault != 0).then(|| fault_name(r.fault)),
            fault_position_mm: fig("fault_position_steps").map(|v| v as f64 / 1e3),
            stop_distance_mm: fig("stop_distance_um").map(|v| v as f64 / 1e3),
            machine_s: r.ticks as f64 / tick_hz as f64,
            control_updates: fig("control_updates").unwrap_or(0),
            lost_steps: fig("lost_steps").unwrap_or(0),
        }
    }

    /// The figures as text lines, beside the plant's steady states.
    pub fn lines(&self, job: &MillingJob) -> Vec<String> {
        let (before, at_step, after) = steady::predict(job);
        let mm_min = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.1} mm/min"));
        let mut out = vec![
            format!(
                "before     force {:.0} N at {} (plant's steady state: {:.0} N at {:.1} mm/min)",
                self.force_before_step_n,
                mm_min(self.feed_before_step_mm_min),
                before.force_n,
                before.feed_mm_min
            ),
            format!(
                "step       peak {:.0} N (plant at the step: {at_step:.0} N); entering the cut {:.0} N",
                self.peak_force_n, self.contact_peak_n
            ),
        ];
        let band = BAND * job.fnom_n;
        out.push(match (self.settle_ms, self.settled) {
            (Some(t), true) => format!(
                "after      back within +-{band:.0} N (10 %) of Fnom {t:.1} ms after the depth \
                 step; dips {:.0} N ({:.1} %) below Fnom; ripple {:.0} N over the last 200 ms",
                self.overshoot_below_fnom_n.unwrap_or(0.0).max(0.0),
                100.0 * self.overshoot_below_fnom_n.unwrap_or(0.0).max(0.0) / job.fnom_n,
                self.late_ripple_n.unwrap_or(0.0)
            ),
            (Some(_), false) => format!(
                "after      NOT back within +-{band:.0} N (10 %) of Fnom in {WINDOW_MS:.0} ms"
            ),
            (None, _) => "after      the cut never reached the depth step".to_string(),
        });
        out.push(format!(
            "           feed {} 300..400 ms after the step (plant's steady state: {:.0} N at \
             {:.1} mm/min)",
            mm_min(self.feed_after_step_mm_min),
            after.force_n,
            after.feed_mm_min
        ));
        out.push(match &self.fault {
            None => "fault      none".to_string(),
            Some(f) => format!(
                "fault      {f}: feed hold at X {:.3} mm, stopped in {:.3} mm",
                self.fault_position_mm.unwrap_or(0.0),
                self.stop_distance_mm.unwrap_or(0.0)
            ),
        });
        out.push(format!(
            "run        {:.3} s of machine time, {} control updates, {} lost steps",
            self.machine_s, self.control_updates, self.lost_steps
        ));
        out
    }

    /// The job and the figures as one JSON object.
    pub fn json(&self, job: &MillingJob) -> Value {
        let mut m = job_json(job);
        let over = self.overshoot_below_fnom_n.map(|v| v.max(0.0));
        for (k, v) in [
            ("force_before_step_n", json!(self.force_before_step_n)),
            ("feed_before_step_mm_min", json!(self.feed_before_step_mm_min)),
            ("contact_peak_n", json!(self.contact_peak_n)),
            ("peak_force_n", json!(self.peak_force_n)),
            ("settle_ms", json!(self.settle_ms)),
            ("settled", json!(self.settled)),
            ("overshoot_below_fnom_n", json!(over)),
            ("overshoot_pct", json!(over.map(|v| 100.0 * v / job.fnom_n))),
            ("late_ripple_n", json!(self.late_ripple_n)),
            ("feed_after_step_mm_min", json!(self.feed_after_step_mm_min)),
            ("fault", json!(self.fault)),
            ("fault_position_mm", json!(self.fault_position_mm)),
            ("stop_distance_mm", json!(self.stop_distance_mm)),
            ("machine_s", json!(self.machine_s)),
            ("control_updates", json!(self.control_updates)),
            ("lost_steps", json!(self.lost_steps)),
        ] {
            m.insert(k.to_string(), v);
        }
        Value::Object(m)
    }
}
