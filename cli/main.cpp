// Entry point; the commands live in cli/commands.cpp.
int meshmux_main(int argc, char** argv);
int main(int argc, char** argv) { return meshmux_main(argc, argv); }
