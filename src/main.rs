fn main() {
    println!("colorvision: being wired");
}
