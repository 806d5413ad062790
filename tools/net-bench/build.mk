TOOLS += net-bench
net-bench_SRCS := tools/net-bench/main.c tools/net-bench/bench.c
# LCM directly for the latency listener (a thread of its own)
net-bench_LIBS := -lpthread
