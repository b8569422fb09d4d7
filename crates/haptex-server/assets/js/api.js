// The JSON API's client: fetch with the server's error ({error, field,
// file}) thrown as an ApiError, JSON POSTs, and the streamed answers
// (application/x-ndjson progress lines) of the check and the compensation.

export class ApiError extends Error {
  constructor(message, field, status, file = null) {
    super(message);
    this.field = field;
    this.status = status;
    this.file = file; // the uploaded file at fault (POST /api/recordings)
  }
}

export async function api(path, options = {}) {
  const response = await fetch(path, options);
  if (!response.ok) {
    let message = `${response.status} ${response.statusText}`;
    let field = null;
    let file = null;
    try {
      const body = await response.json();
      message = body.error || message;
      field = body.field || null;
      file = body.file || null;
    } catch (_) { /* not JSON */ }
    throw new ApiError(message, field, response.status, file);
  }
  return response;
}

export const postJson = (path, body) =>
  api(path, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });

/**
 * POSTs `body` and reads the answer's JSON lines (application/x-ndjson):
 * each {progress} goes to onProgress, the {result} line is returned, an
 * {error} line is thrown as an ApiError (a 4xx or 503 before the stream
 * is thrown by api() as usual).
 */
export async function postStream(path, body, onProgress) {
  const response = await postJson(path, body);
  const reader = response.body.getReader();
  const decoder = new TextDecoder();
  let buffer = '';
  for (;;) {
    const { value, done } = await reader.read();
    buffer += decoder.decode(value || new Uint8Array(), { stream: !done });
    let end;
    while ((end = buffer.indexOf('\n')) >= 0) {
      const line = buffer.slice(0, end).trim();
      buffer = buffer.slice(end + 1);
      if (!line) continue;
      const message = JSON.parse(line);
      if (message.progress) onProgress(message.progress);
      else if (message.result) return message.result;
      else if (message.error) throw new ApiError(message.error, message.field, message.status);
    }
    if (done) throw new ApiError(`${path}: the answer ended without a result`, null, 0);
  }
}
