//! `colorvision`: see `colorvision --help`.

fn main() {
    colorvision::program::main()
}
