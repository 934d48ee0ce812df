//! Generates the gRPC code from `proto/buridan/v1/learner.proto`,
//! `proto/buridan/v1/env.proto` and `proto/buridan/v1/control.proto` with the vendored `protoc`, so a fresh
//! machine needs nothing but cargo.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let protoc = protoc_bin_vendored::protoc_bin_path()?;
    std::env::set_var("PROTOC", protoc);
    println!("cargo:rerun-if-changed=proto/buridan/v1/learner.proto");
    println!("cargo:rerun-if-changed=proto/buridan/v1/env.proto");
    println!("cargo:rerun-if-changed=proto/buridan/v1/control.proto");
    // Undecodable requests get INVALID_ARGUMENT (src/codec.rs).
    tonic_prost_build::configure()
        .codec_path("crate::codec::WireCodec")
        .compile_protos(
            &[
                "proto/buridan/v1/learner.proto",
                "proto/buridan/v1/env.proto",
                "proto/buridan/v1/control.proto",
            ],
            &["proto"],
        )?;
    Ok(())
}
