//! Actor inference throughput on one thread: a batch of 64 local
//! observations (129 floats, [64, 64] tanh MLP) → masked sampling.
//!
//! `cargo bench -p buridan-policy --bench inference`

use buridan_policy::{ActMode, Inference, LstmSpec, Mode, ModelSpec, Policy};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

fn bench(c: &mut Criterion) {
    buridan_policy::threads::pin_threads(1);
    let rows = 64;
    let obs: Vec<f32> = (0..rows * 129)
        .map(|i| ((i * 31 % 7) == 0) as u8 as f32)
        .collect();
    let masks: Vec<u8> = (0..rows * 5)
        .map(|i| u8::from(i % 5 == 0 || i % 3 == 0))
        .collect();
    let mut actions = vec![0u8; rows];
    let mut logp = vec![0f32; rows];
    let mut g = c.benchmark_group("inference");
    g.throughput(Throughput::Elements(rows as u64));
    let ff = ModelSpec::new(Mode::Ctde, 4, 129);
    let mut inf = Inference::new(Policy::new(ff, 0).unwrap(), rows, 0);
    g.bench_function("mlp_64x64_batch_64", |b| {
        b.iter(|| {
            inf.act(&obs, &masks, ActMode::Sample, &mut actions, &mut logp)
                .unwrap();
        })
    });
    let rec = ModelSpec {
        lstm: Some(LstmSpec::default()),
        ..ModelSpec::new(Mode::Ctde, 4, 129)
    };
    let mut inf = Inference::new(Policy::new(rec, 0).unwrap(), rows, 0);
    g.bench_function("mlp_64x64_lstm_64_batch_64", |b| {
        b.iter(|| {
            inf.act(&obs, &masks, ActMode::Sample, &mut actions, &mut logp)
                .unwrap();
        })
    });
    let dte = ModelSpec::new(Mode::Dte, 4, 129);
    let mut inf = Inference::new(Policy::new(dte, 0).unwrap(), rows, 0);
    g.bench_function("dte_4_nets_batch_64", |b| {
        b.iter(|| {
            inf.act(&obs, &masks, ActMode::Sample, &mut actions, &mut logp)
                .unwrap();
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
