float leaf_value() {
    return 1.0;
}
