fn main() -> anyhow::Result<()> {
    println!("fringe3d: under construction");
    Ok(())
}
