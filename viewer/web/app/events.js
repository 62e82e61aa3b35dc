// Live object events: GET api/events (Server-Sent Events) read with fetch, so that the bearer
// header goes along when tokens are on (EventSource cannot send headers). Reconnects after a
// drop; `onReady` runs on every (re)connection, once the server has subscribed the stream.
import { authHeaders } from './api.js';

const RETRY_MS = 2000;
const FULL_RETRY_MS = 10000;
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

export async function followEvents({ onReady, onEvent, onState }) {
  for (;;) {
    let retry = RETRY_MS;
    try {
      const res = await fetch('api/events', { headers: authHeaders(), cache: 'no-store' });
      if (res.ok) {
        await readStream(res.body, { onReady, onEvent, onState });
        onState('disconnected');
      } else {
        onState(res.status === 503 ? 'server full' : 'HTTP ' + res.status);
        retry = FULL_RETRY_MS;
      }
    } catch (e) {
      onState('disconnected');
    }
    await sleep(retry);
  }
}

async function readStream(body, { onReady, onEvent, onState }) {
  const reader = body.pipeThrough(new TextDecoderStream()).getReader();
  let buffer = '';
  for (;;) {
    const { value, done } = await reader.read();
    if (done) return;
    buffer += value;
    let end;
    while ((end = buffer.indexOf('\n\n')) >= 0) {
      const block = parseBlock(buffer.slice(0, end));
      buffer = buffer.slice(end + 2);
      if (block.event === 'ready') {
        onState('live');
        await onReady();
      } else if (block.event === 'object') {
        onEvent(JSON.parse(block.data));
      }
    }
  }
}

// One SSE block: its `event:` and joined `data:` lines (comments and `retry:` ignored).
function parseBlock(text) {
  const out = { event: 'message', data: '' };
  const data = [];
  for (const line of text.split('\n')) {
    if (line.startsWith('event:')) out.event = line.slice(6).trim();
    else if (line.startsWith('data:')) data.push(line.slice(5).replace(/^ /, ''));
  }
  out.data = data.join('\n');
  return out;
}
