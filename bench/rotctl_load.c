/* rotctld load generator for bench/rotctld_bench.py: N clients, a thread and a TCP
 * connection each, every client sending "p\n" and reading its two reply lines, for S
 * seconds. Compiled (no interpreter, no GIL) so that on a 2-core machine the generator
 * is not what limits the throughput measured: a Python client thread costs as much CPU
 * per request as the server it measures.
 *
 * Usage: rotctl_load HOST PORT CLIENTS SECONDS
 * Prints one line: requests errors elapsed_s median_ms p99_ms
 */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define MAX_RTTS 4000000

static const char *host;
static int port;
static double seconds;
static pthread_barrier_t start;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static double *rtts;
static long n_rtts;
static int errors;

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* Read until `lines` newlines have arrived (a p reply is "az\nel\n"). */
static int read_lines(int fd, int lines) {
    char buf[256];
    while (lines > 0) {
        ssize_t n = read(fd, buf, sizeof buf);
        if (n <= 0)
            return -1;
        for (ssize_t i = 0; i < n; i++)
            if (buf[i] == '\n')
                lines--;
    }
    return 0;
}

static void *client(void *arg) {
    (void)arg;
    double local_cap = 200000, *local = malloc(sizeof(double) * (size_t)local_cap);
    long k = 0;
    int fd = socket(AF_INET, SOCK_STREAM, 0), one = 1, failed = 0;
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    inet_pton(AF_INET, host, &sa.sin_addr);
    if (fd < 0 || connect(fd, (struct sockaddr *)&sa, sizeof sa) != 0)
        failed = 1;
    else
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    pthread_barrier_wait(&start);
    double end = now_s() + seconds;
    while (!failed && now_s() < end && k < (long)local_cap) {
        double t0 = now_s();
        if (write(fd, "p\n", 2) != 2 || read_lines(fd, 2) != 0) {
            failed = 1;
            break;
        }
        local[k++] = now_s() - t0;
    }
    if (fd >= 0)
        close(fd);
    pthread_mutex_lock(&lock);
    errors += failed;
    for (long i = 0; i < k && n_rtts < MAX_RTTS; i++)
        rtts[n_rtts++] = local[i];
    pthread_mutex_unlock(&lock);
    free(local);
    return NULL;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: %s HOST PORT CLIENTS SECONDS\n", argv[0]);
        return 2;
    }
    host = argv[1];
    port = atoi(argv[2]);
    int clients = atoi(argv[3]);
    seconds = atof(argv[4]);
    rtts = malloc(sizeof(double) * MAX_RTTS);
    pthread_t *threads = malloc(sizeof(pthread_t) * (size_t)clients);
    pthread_barrier_init(&start, NULL, (unsigned)clients + 1);
    for (int i = 0; i < clients; i++)
        pthread_create(&threads[i], NULL, client, NULL);
    pthread_barrier_wait(&start);
    double t0 = now_s();
    for (int i = 0; i < clients; i++)
        pthread_join(threads[i], NULL);
    double elapsed = now_s() - t0;
    qsort(rtts, (size_t)n_rtts, sizeof(double), cmp);
    double median = n_rtts ? rtts[n_rtts / 2] : 0, p99 = n_rtts ? rtts[(long)(0.99 * (n_rtts - 1))] : 0;
    printf("%ld %d %.6f %.6f %.6f\n", n_rtts, errors, elapsed, 1000 * median, 1000 * p99);
    return 0;
}
