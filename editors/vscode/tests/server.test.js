'use strict';
// End to end: start the server the way extension.js does (same command, same arguments, the
// same JSON-RPC stack as vscode-languageclient), open a document with an error and wait for
// the compiler's diagnostic. MPLANG_SERVER_PATH names the mpc executable (default: the
// project's .venv/bin/mpc if there is one, else `mpc` on PATH).

const assert = require('node:assert/strict');
const cp = require('node:child_process');
const fs = require('node:fs');
const path = require('node:path');
const { test } = require('node:test');
const {
  createProtocolConnection,
  StreamMessageReader,
  StreamMessageWriter,
} = require('vscode-languageserver-protocol/node');

const { serverCommand } = loadServerCommand();

/** extension.js without VS Code: only its pure serverCommand is used here. */
function loadServerCommand() {
  const Module = require('node:module');
  const originalLoad = Module._load;
  Module._load = function load(request, parent, isMain) {
    if (request === 'vscode' || request === 'vscode-languageclient/node') {
      return {};
    }
    return originalLoad.call(this, request, parent, isMain);
  };
  try {
    return require('../extension.js');
  } finally {
    Module._load = originalLoad;
  }
}

/** The server failed: the message names the command and carries its stderr. */
class ServerFailure extends Error {}

const BROKEN = 'MP 1 demo\n    FIXED_MOVE X\nEND MP\n';

test('mpc lsp answers initialize and publishes diagnostics for an open document', async () => {
  const root = path.resolve(__dirname, '..', '..', '..');
  const venvMpc = path.join(root, '.venv', 'bin', 'mpc');
  const setting = process.env.MPLANG_SERVER_PATH || (fs.existsSync(venvMpc) ? venvMpc : undefined);
  const { command, args } = serverCommand(setting, root);
  const commandLine = `${command} ${args.join(' ')}`;
  const server = cp.spawn(command, args, { cwd: root });
  let stderr = '';
  server.stderr.on('data', (chunk) => { stderr += chunk.toString(); });
  const exited = new Promise((resolve) => server.on('close', resolve));
  // Any failure names the command and shows what the server wrote to stderr.
  const failure = (reason) => new ServerFailure(
    `${commandLine}: ${reason}\nserver stderr:\n${stderr}`);
  const stopped = new Promise((_, reject) => {
    server.on('error', (error) => reject(failure(error.message)));
    exited.then((code) => reject(failure(`exited with ${code}`)));
  });
  stopped.catch(() => {});
  const answer = (promise, what) => {
    promise.catch(() => {});
    const timeout = new Promise((_, reject) => setTimeout(
      () => reject(failure(`${what} timed out`)), 20000).unref());
    return Promise.race([promise, stopped, timeout]);
  };
  const connection = createProtocolConnection(
    new StreamMessageReader(server.stdout), new StreamMessageWriter(server.stdin));
  const diagnostics = new Promise((resolve) => {
    connection.onNotification('textDocument/publishDiagnostics', (params) => {
      if (params.diagnostics.length > 0) {
        resolve(params);
      }
    });
  });
  connection.onError(() => {});
  connection.listen();
  const uri = `file://${path.join(root, 'editors-test-broken.mp')}`;
  try {
    const initialized = await answer(connection.sendRequest('initialize',
      { processId: process.pid, rootUri: `file://${root}`, capabilities: {} }), 'initialize');
    assert.ok(initialized.capabilities.textDocumentSync !== undefined,
      'the server announces how documents are synchronised');
    await answer(connection.sendNotification('initialized', {}), 'initialized');
    await answer(connection.sendNotification('textDocument/didOpen', {
      textDocument: { uri, languageId: 'mplang', version: 1, text: BROKEN },
    }), 'didOpen');
    const published = await answer(diagnostics, 'publishDiagnostics');
    assert.equal(published.uri, uri);
    const [first] = published.diagnostics;
    assert.equal(first.range.start.line, 1, 'the error is on the FIXED_MOVE line (0-based 1)');
    assert.match(String(first.code), /^E\d{3}$/);
    await answer(connection.sendRequest('shutdown'), 'shutdown');
    connection.sendNotification('exit').catch(() => {});
    const timeout = new Promise((_, reject) => setTimeout(
      () => reject(failure('exit timed out')), 20000).unref());
    assert.equal(await Promise.race([exited, timeout]), 0, 'the server exits 0 after shutdown');
  } catch (error) {
    if (error instanceof assert.AssertionError || error instanceof ServerFailure) {
      throw error;
    }
    const code = await Promise.race([exited, new Promise((r) => setTimeout(r, 3000, 'none'))]);
    throw failure(`${error.message} (exit code ${code})`);
  } finally {
    connection.dispose();
    server.kill();
  }
});
