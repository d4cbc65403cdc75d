// uses an undeclared name on line 3
float uses_undeclared() {
    return not_declared_anywhere;
}
