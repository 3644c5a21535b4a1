//! The `multifield` command line with the external power-law plugin linked in
//! (docs/plugins.md): `cargo run --release --example multifield_with_power_law -- plugins`.

fn main() -> std::process::ExitCode {
    multifield_power_law::link();
    multifield::cli::main()
}
