float slot_value() {
    return 7.0;
}
