// HTTP access to `strata serve` (docs/viewer.md) and the request discipline the views share.

export class ApiError extends Error {
  constructor(status, message, parameter) {
    super(message);
    this.status = status;
    this.parameter = parameter;
  }
}

// Throws ApiError with the server's JSON error body when the response is not OK.
export async function checked(response) {
  if (response.ok) return response;
  let message = `${response.status} ${response.statusText}`;
  let parameter;
  try {
    const body = await response.json();
    if (body.error) message = body.error;
    parameter = body.parameter;
  } catch {
    // not JSON: keep the status line
  }
  throw new ApiError(response.status, message, parameter);
}

export async function getJson(url, options = {}) {
  const response = await checked(await fetch(url, options));
  return response.json();
}

export async function postJson(url, body, options = {}) {
  const response = await fetch(url, {
    ...options,
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
  });
  return (await checked(response)).json();
}

// Builds "/api/datasets/{id}/{endpoint}?k=v&..." skipping null/undefined parameters.
export function apiUrl(id, endpoint, params = {}) {
  const query = new URLSearchParams();
  for (const [key, value] of Object.entries(params)) {
    if (value === null || value === undefined) continue;
    query.set(key, Array.isArray(value) ? value.join(',') : String(value));
  }
  const text = query.toString();
  return `/api/datasets/${id}/${endpoint}${text ? `?${text}` : ''}`;
}

export const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

// The delay a 503 asks for (Retry-After, seconds), capped so an interactive view stays lively.
export function retryDelayMs(response) {
  const seconds = Number(response.headers.get('Retry-After'));
  return Number.isFinite(seconds) && seconds > 0 ? Math.min(seconds * 1000, 1000) : 250;
}

// One request at a time, newest wins: while a job runs, later submissions replace each other
// as the single pending job, so a view never builds a queue of stale frames on the server.
// A running job marked `abortable` is cancelled when a newer job arrives (an exact frame that
// the user has already moved away from).
export class LatestChannel {
  constructor(onError = (error) => console.error(error)) {
    this.running = null;
    this.pending = null;
    this.onError = onError;
  }

  // job: { run(signal, channel) -> Promise, abortable?: boolean }
  submit(job) {
    if (!this.running) {
      this.start(job);
      return;
    }
    this.pending = job;
    if (this.running.job.abortable) this.running.controller.abort();
  }

  get hasPending() {
    return this.pending !== null;
  }

  get busy() {
    return this.running !== null;
  }

  async start(job) {
    const controller = new AbortController();
    this.running = { job, controller };
    try {
      await job.run(controller.signal, this);
    } catch (error) {
      if (error.name !== 'AbortError') this.onError(error);
    }
    this.running = null;
    const next = this.pending;
    this.pending = null;
    if (next) this.start(next);
  }
}

// Fetches an image, retrying while the server's render queue is full (503) unless a newer job
// is already waiting. Returns null when the server superseded the request (204) or a newer job
// made the retry pointless.
export async function fetchImage(url, signal, channel) {
  for (;;) {
    const response = await fetch(url, { signal });
    if (response.status === 204) return null;
    if (response.status === 503) {
      if (channel?.hasPending) return null;
      await sleep(retryDelayMs(response));
      if (channel?.hasPending) return null;
      continue;
    }
    await checked(response);
    const blob = await response.blob();
    const bitmap = await createImageBitmap(blob);
    return { blob, bitmap, headers: response.headers };
  }
}
