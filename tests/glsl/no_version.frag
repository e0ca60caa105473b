// no version line
void main() {}
