//! Build script. With the `gpu` feature it validates and embeds the WGSL stages
//! ([`build/shaders.rs`](build/shaders.rs)); without it there is nothing to build.

#[cfg(feature = "gpu")]
#[path = "build/shaders.rs"]
mod shaders;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    #[cfg(feature = "gpu")]
    shaders::main();
}
