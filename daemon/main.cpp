// Placeholder until the command line lands; keeps the tree building.
int main() { return 0; }
