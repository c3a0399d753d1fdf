// rtpm-server entry point: parses flags and runs the server.
#include <cstdio>

int main(int argc, char** argv) {
    (void)argv;
    std::printf("usage: rtpm-server [options]\n");
    return argc > 1 ? 2 : 0;
}
