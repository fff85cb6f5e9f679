//! Prints what the kernel left out of a recording and its estimate (f32).
fn main() {
    let path = std::env::args().nth(1).expect("usage: counters REC.csv");
    let rec =
        reference_f64::recording::Recording::read(std::path::Path::new(&path)).expect("recording");
    let sat = reference_f64::satellite::Satellite::builtin(rec.satellite().unwrap_or("sph2"))
        .expect("sat");
    let p = massid_kernel_host::run::<f32>(&rec, &sat).expect("run");
    let e = p.estimates();
    println!("{:?}", e.data);
    println!(
        "status {:?} invalid {:?} unobs {:?} {:?}",
        e.status, e.invalid, e.unobservable_com, e.unobservable_inertia
    );
    println!("com {:?} I {:?}", e.com_offset_mm(), e.inertia_kgm2());
    println!(
        "vf {:?}",
        p.mass_id().variance_factors().map(|v| v.to_f64())
    );
    println!("est {:?}", massid_kernel_host::to_estimate(&p, &sat));
}
