//! Per-pass GPU times from timestamp queries, as a table or a Chrome trace (Perfetto opens it).

/// The GPU time of one pass.
#[derive(Clone, Debug)]
pub struct PassTiming {
    pub name: String,
    /// Start of the pass relative to the first timestamp of the submission.
    pub start_ms: f64,
    pub gpu_ms: f64,
}

/// GPU times of one submission.
#[derive(Clone, Debug, Default)]
pub struct Profile {
    pub device: String,
    pub passes: Vec<PassTiming>,
    /// Host wall time from submit to fence.
    pub submit_wall_ms: f64,
    /// When the work was submitted (host clock), for a caller's start-up time.
    pub submitted_at: Option<std::time::Instant>,
    /// The device memory in use when the work was submitted: every image and buffer of the
    /// recording is alive then (the recorder keeps them until the fence), so this is the
    /// frame's peak (with what the pool keeps idle from earlier frames).
    pub gpu_memory_bytes: u64,
    /// The allocator's memory blocks then, used or not (what the device gave the process).
    pub gpu_memory_held_bytes: u64,
}

impl Profile {
    pub fn total_gpu_ms(&self) -> f64 {
        self.passes.iter().map(|p| p.gpu_ms).sum()
    }

    /// The GPU time of the pass called `name` (summed if it ran several times).
    pub fn pass_ms(&self, name: &str) -> Option<f64> {
        let hits: Vec<_> = self.passes.iter().filter(|p| p.name == name).collect();
        (!hits.is_empty()).then(|| hits.iter().map(|p| p.gpu_ms).sum())
    }

    /// Adds `other`'s times to these (banded rendering: a frame's bands): each pass's GPU time
    /// to the first of this profile's of the same name (or as a pass of its own), and the
    /// submit's wall time; the memory held is the larger.
    pub fn add(&mut self, other: &Profile) {
        for pass in &other.passes {
            match self.passes.iter_mut().find(|p| p.name == pass.name) {
                Some(p) => p.gpu_ms += pass.gpu_ms,
                None => self.passes.push(pass.clone()),
            }
        }
        self.submit_wall_ms += other.submit_wall_ms;
        self.gpu_memory_bytes = self.gpu_memory_bytes.max(other.gpu_memory_bytes);
        self.gpu_memory_held_bytes = self.gpu_memory_held_bytes.max(other.gpu_memory_held_bytes);
    }

    /// The device memory in use at the submit, per pixel of a frame of `pixels`, and the
    /// allocator's blocks.
    pub fn memory_line(&self, pixels: u64) -> String {
        format!(
            "GPU memory in use at the submit: {:.1} MB, {:.0} bytes per pixel of the frame ({:.1} MB in the allocator's blocks)",
            self.gpu_memory_bytes as f64 / 1e6,
            self.gpu_memory_bytes as f64 / pixels.max(1) as f64,
            self.gpu_memory_held_bytes as f64 / 1e6
        )
    }

    /// A plain-text table, one line per pass.
    pub fn table(&self) -> String {
        let mut out = format!("GPU time per pass on {}:\n", self.device);
        for p in &self.passes {
            out += &format!("  {:<24} {:>10.3} ms\n", p.name, p.gpu_ms);
        }
        out += &format!(
            "  {:<24} {:>10.3} ms  (submit to fence: {:.3} ms wall)\n",
            "total",
            self.total_gpu_ms(),
            self.submit_wall_ms
        );
        out
    }

    /// Chrome trace-event JSON ("X" complete events, microseconds), for chrome://tracing or Perfetto.
    pub fn chrome_trace_json(&self) -> String {
        let events: Vec<String> = self
            .passes
            .iter()
            .map(|p| {
                format!(
                    r#"{{"name":"{}","cat":"gpu","ph":"X","pid":1,"tid":1,"ts":{:.3},"dur":{:.3}}}"#,
                    json_escape(&p.name),
                    p.start_ms * 1e3,
                    p.gpu_ms * 1e3
                )
            })
            .collect();
        format!(
            "{{\"displayTimeUnit\":\"ms\",\"otherData\":{{\"device\":\"{}\"}},\"traceEvents\":[\n{}\n]}}\n",
            json_escape(&self.device),
            events.join(",\n")
        )
    }
}

fn json_escape(s: &str) -> String {
    s.chars()
        .flat_map(|c| match c {
            '"' => vec!['\\', '"'],
            '\\' => vec!['\\', '\\'],
            c if (c as u32) < 0x20 => format!("\\u{:04x}", c as u32).chars().collect(),
            c => vec![c],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chrome_trace_has_one_complete_event_per_pass_in_microseconds() {
        let p = Profile {
            device: "dev \"x\"".into(),
            passes: vec![
                PassTiming { name: "coc".into(), start_ms: 0.0, gpu_ms: 1.5 },
                PassTiming { name: "bokeh".into(), start_ms: 1.5, gpu_ms: 2.25 },
            ],
            submit_wall_ms: 4.0,
            submitted_at: None,
            gpu_memory_bytes: 0,
            gpu_memory_held_bytes: 0,
        };
        let json = p.chrome_trace_json();
        assert!(json.contains(r#""name":"bokeh","cat":"gpu","ph":"X","pid":1,"tid":1,"ts":1500.000,"dur":2250.000"#));
        assert!(json.contains(r#"dev \"x\""#));
        assert_eq!(json.matches("\"ph\":\"X\"").count(), 2);
        assert!((p.total_gpu_ms() - 3.75).abs() < 1e-12);
    }
}
