//! Prints a built-in model as a model file (TOML): `cargo run -p reference-f64 --example dump_model -- sph2`.
fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "sph2".into());
    match reference_f64::satellite::Satellite::builtin(&name) {
        Some(s) => print!("{}", s.to_toml_string()),
        None => {
            eprintln!("unknown satellite {name}");
            std::process::exit(1);
        }
    }
}
