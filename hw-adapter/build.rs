//! Compiles the Kortex message definitions (proto/, see each file for its source) with prost;
//! protox parses them, so no protoc binary is needed.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    const FILES: [&str; 5] = [
        "proto/Frame.proto",
        "proto/Session.proto",
        "proto/Common.proto",
        "proto/Base.proto",
        "proto/BaseCyclic.proto",
    ];
    for f in FILES {
        println!("cargo:rerun-if-changed={f}");
    }
    let descriptors = protox::compile(FILES, ["proto"])?;
    prost_build::Config::new().compile_fds(descriptors)?;
    Ok(())
}
