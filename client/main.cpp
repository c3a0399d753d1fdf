// rtpm-client entry point: parses flags and runs the client.
#include <cstdio>

int main(int argc, char** argv) {
    (void)argv;
    std::printf("usage: rtpm-client [options]\n");
    return argc > 1 ? 2 : 0;
}
