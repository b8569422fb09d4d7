//! Speed of a template prediction on the shipped FE database (issue 5):
//! `data/db`, 180 FE profiles per template (9 widths x 5 heights x 4
//! velocities), 501 outputs, the leave-one-out widths of its metadata.
//! Run: `cargo bench -p haptex-core --bench database`.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use haptex_core::database::{Metadata, Template, TemplateModel};

fn bench(c: &mut Criterion) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/db");
    let metadata = Metadata::read(&dir).expect("the shipped database");
    c.bench_function("database_load_bump", |b| {
        b.iter(|| TemplateModel::load_with(black_box(&dir), &metadata, Template::Bump).unwrap())
    });
    for template in Template::ALL {
        let model = TemplateModel::load_with(&dir, &metadata, template).unwrap();
        let mut scratch = model.cae.scratch();
        let mut out = vec![0.0; model.grid.points];
        // Between database rows (r_w 1.25/1.5, r_h 0.2/0.3, v 20/50).
        let query = [1.3, 0.27, 30.0];
        c.bench_function(&format!("database_predict_{}", template.name()), |b| {
            b.iter(|| model.predict_into(black_box(&query), &mut scratch, &mut out).unwrap())
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
