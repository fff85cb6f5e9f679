fn main() {
    let mut out = String::new();
    let _ = massid_qemu_runner::run_all(&mut out);
    print!("{out}");
}
