//! Fuzzes the live-stream line reader and the compensator behind it: any bytes as a header
//! and lines must give exactly one output line per input line, and never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles_core::model::design::Design;
use tolles_core::compensate::stream::{Derivative, Sample, ScalarSpec, StreamCompensator};
use tolles_io::stream_line::{split_fields, Layout};

const HEADER: &str = "tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z";

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = split_fields(text);
        let _ = Layout::from_header(text, &["mag_1_uc"], &["flux_a"], &["mag_1_c"]);
    }
    let layout = Layout::from_header(HEADER, &["mag_1_uc"], &["flux_a"], &["mag_1_c"]).unwrap();
    let design = Design::new("p,i,e".parse().unwrap());
    let beta = vec![1.0; design.width()];
    let spec = ScalarSpec::new("mag_1_uc", 0, design, &beta, 0.0, 1.0);
    let mut stream =
        StreamCompensator::new(vec![spec], vec!["flux_a".into()], 10.0, Derivative::Central);
    let mut out = String::new();
    let mut emitted = 0;
    let mut check = |o: tolles_core::compensate::stream::Output<'_, (usize, tolles_io::stream_line::Line)>| {
        let (k, line) = &o.payload;
        assert_eq!(*k, emitted, "in order");
        emitted += 1;
        out.clear();
        layout.write_output(line, o.compensated, &o.status(), &mut out);
        assert_eq!(out.matches('\n').count(), 1, "one output line");
    };
    let lines: Vec<&[u8]> = data.split(|b| *b == b'\n').collect();
    for (k, raw) in lines.iter().enumerate() {
        let line = layout.parse(raw);
        let (scalars, fluxgates, flags) = (
            line.scalars.clone(),
            line.fluxgates.clone(),
            line.flags.iter().map(tolles::stream::flag).collect(),
        );
        let sample = line.well_formed.then_some(Sample {
            time_s: line.time_s,
            scalars: &scalars,
            fluxgates: &fluxgates,
            extras: &[],
        });
        stream.push((k, line), sample, flags, &mut check);
    }
    stream.finish(&mut check);
    assert_eq!(emitted, lines.len(), "one out per line in");
});
