//! Evaluates a synthetic scene held in memory: the library's entry point
//! without a file in sight. `cargo run --release --example evaluate`
use mapgauge::cloud::MapSource;
use mapgauge::pipeline::{self, Config};
use mapgauge::synth::{self, SynthParams};

fn main() -> mapgauge::Result<()> {
    // A 2 M-point LiDAR scene with five surveyed L-targets and known truth.
    let mut map = Vec::new();
    let truth = synth::generate(&SynthParams::default(), &mut |pts| {
        map.extend_from_slice(pts);
        Ok(())
    })?;
    let survey = truth.survey();

    let ev = pipeline::run(
        MapSource::Points(&map),
        &survey,
        &Config::default(),
        |_, _| {},
    )?;

    let (abs, rel) = (&ev.accuracy.absolute, &ev.accuracy.relative.summary);
    println!("E_abs {:.4} m  σ_abs {:.4} m", abs.mean, abs.std);
    println!("E_rel {:.4} m  σ_rel {:.4} m", rel.mean, rel.std);
    for (t, tt) in ev.targets.iter().zip(&truth.targets) {
        match &t.outcome {
            Ok(f) => {
                let c = f.located.corner;
                let mm = 1e3 * (c.x - tt.map[0]).hypot(c.y - tt.map[1]);
                println!("target {}: {mm:.1} mm from the truth", t.id);
            }
            Err(why) => println!("target {}: not found ({why})", t.id),
        }
    }
    Ok(())
}
