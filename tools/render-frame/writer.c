/* writer.c — the PNG writing thread (writer.h). */
#include "writer.h"
#include "png.h"

#include "ndo/status.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct job {
	uint8_t *pixels;
	char *path, *description;
} job;

struct rf_writer {
	int width, height, compression;
	uint8_t *buf[2];
	int next;             /* the buffer the caller fills next */
	pthread_mutex_t lock;
	pthread_cond_t cond;
	pthread_t thread;
	int started;
	job queue[2];         /* at most two: one per buffer */
	int head, count;
	int busy;             /* the thread is writing queue[head] */
	int quit;
	int failed;           /* first failure's status, 0 if none */
	char detail[512];
};

static void free_job(job *j)
{
	free(j->path);
	free(j->description);
	memset(j, 0, sizeof *j);
}

static void *run(void *arg)
{
	rf_writer *w = arg;
	pthread_mutex_lock(&w->lock);
	for (;;) {
		while (w->count == 0 && !w->quit)
			pthread_cond_wait(&w->cond, &w->lock);
		if (w->count == 0)
			break;
		job j = w->queue[w->head];
		w->busy = 1;
		pthread_mutex_unlock(&w->lock);
		int rc = w->failed ? NDO_OK
		                   : rf_png_write(j.path, j.pixels, w->width, w->height,
		                                  w->compression, j.description);
		pthread_mutex_lock(&w->lock);
		if (rc != NDO_OK && !w->failed) {
			w->failed = rc;
			snprintf(w->detail, sizeof w->detail, "%s", ndo_errdetail());
		}
		free_job(&w->queue[w->head]);
		w->head = (w->head + 1) % 2;
		w->count--;
		w->busy = 0;
		pthread_cond_broadcast(&w->cond);
	}
	pthread_mutex_unlock(&w->lock);
	return NULL;
}

int rf_writer_create(int width, int height, int compression, rf_writer **out)
{
	*out = NULL;
	rf_writer *w = calloc(1, sizeof *w);
	if (!w)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	w->width = width;
	w->height = height;
	w->compression = compression;
	size_t bytes = (size_t)width * (size_t)height * 4;
	w->buf[0] = malloc(bytes);
	w->buf[1] = malloc(bytes);
	pthread_mutex_init(&w->lock, NULL);
	pthread_cond_init(&w->cond, NULL);
	if (!w->buf[0] || !w->buf[1]) {
		rf_writer_destroy(w);
		return ndo__fail(NDO_ENOMEM, "out of memory for two %dx%d images", width, height);
	}
	if (pthread_create(&w->thread, NULL, run, w) != 0) {
		rf_writer_destroy(w);
		return ndo__fail(NDO_ENOMEM, "cannot start the PNG writing thread");
	}
	w->started = 1;
	*out = w;
	return NDO_OK;
}

uint8_t *rf_writer_buffer(rf_writer *w)
{
	/* The buffer is free once no queued job points at it. */
	pthread_mutex_lock(&w->lock);
	for (;;) {
		int in_use = 0;
		for (int k = 0; k < w->count; k++)
			in_use |= w->queue[(w->head + k) % 2].pixels == w->buf[w->next];
		if (!in_use)
			break;
		pthread_cond_wait(&w->cond, &w->lock);
	}
	pthread_mutex_unlock(&w->lock);
	return w->buf[w->next];
}

int rf_writer_submit(rf_writer *w, const char *path, const char *description)
{
	job j = {w->buf[w->next], strdup(path), description ? strdup(description) : NULL};
	if (!j.path || (description && !j.description)) {
		free_job(&j);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	pthread_mutex_lock(&w->lock);
	while (w->count == 2)
		pthread_cond_wait(&w->cond, &w->lock);
	w->queue[(w->head + w->count) % 2] = j;
	w->count++;
	w->next ^= 1;
	int failed = w->failed;
	pthread_cond_broadcast(&w->cond);
	pthread_mutex_unlock(&w->lock);
	return failed ? ndo__fail(failed, "%s", w->detail) : NDO_OK;
}

int rf_writer_finish(rf_writer *w)
{
	pthread_mutex_lock(&w->lock);
	while (w->count > 0)
		pthread_cond_wait(&w->cond, &w->lock);
	int failed = w->failed;
	pthread_mutex_unlock(&w->lock);
	return failed ? ndo__fail(failed, "%s", w->detail) : NDO_OK;
}

void rf_writer_destroy(rf_writer *w)
{
	if (!w)
		return;
	if (w->started) {
		pthread_mutex_lock(&w->lock);
		w->quit = 1;
		pthread_cond_broadcast(&w->cond);
		pthread_mutex_unlock(&w->lock);
		pthread_join(w->thread, NULL);
	}
	for (int k = 0; k < 2; k++)
		free_job(&w->queue[k]);
	pthread_mutex_destroy(&w->lock);
	pthread_cond_destroy(&w->cond);
	free(w->buf[0]);
	free(w->buf[1]);
	free(w);
}
