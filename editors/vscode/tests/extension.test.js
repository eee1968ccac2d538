'use strict';
// Tests of extension.js without VS Code: the `vscode` module and the language client are
// replaced by recording fakes, so that what the extension asks for can be checked.
// Run with `node --test tests/` (tests/tools/test_editors.py does).

const assert = require('node:assert/strict');
const Module = require('node:module');
const os = require('node:os');
const path = require('node:path');
const { test, beforeEach } = require('node:test');

const fake = {
  settings: {},
  commands: {},
  configurationListeners: [],
  errors: [],
  clients: [],
  adapterFactories: {},
  taskProviders: {},
  failStart: undefined,
  workspaceFolders: [{ uri: { fsPath: path.join(os.tmpdir(), 'project') } }],
};

class FakeLanguageClient {
  constructor(id, name, serverOptions, clientOptions) {
    Object.assign(this, { id, name, serverOptions, clientOptions });
    this.running = false;
    this.stopped = false;
    fake.clients.push(this);
  }

  async start() {
    if (fake.failStart !== undefined) {
      throw new Error(fake.failStart);
    }
    this.running = true;
  }

  isRunning() {
    return this.running;
  }

  async stop() {
    this.running = false;
    this.stopped = true;
  }
}

const fakeVscode = {
  workspace: {
    get workspaceFolders() {
      return fake.workspaceFolders;
    },
    getConfiguration(section) {
      assert.equal(section, 'mplang');
      return { get: (key) => fake.settings[key] };
    },
    onDidChangeConfiguration(listener) {
      fake.configurationListeners.push(listener);
      return { dispose() {} };
    },
  },
  commands: {
    registerCommand(name, callback) {
      fake.commands[name] = callback;
      return { dispose() {} };
    },
  },
  window: {
    showErrorMessage(message) {
      fake.errors.push(message);
    },
  },
  debug: {
    registerDebugAdapterDescriptorFactory(type, factory) {
      fake.adapterFactories[type] = factory;
      return { dispose() {} };
    },
  },
  tasks: {
    registerTaskProvider(type, provider) {
      fake.taskProviders[type] = provider;
      return { dispose() {} };
    },
  },
  Task: class {
    constructor(definition, scope, name, source, execution, problemMatchers) {
      Object.assign(this, { definition, scope, name, source, execution, problemMatchers });
    }
  },
  ProcessExecution: class {
    constructor(process, args, options) {
      Object.assign(this, { process, args, options });
    }
  },
  TaskGroup: { Build: 'build-group' },
  DebugAdapterExecutable: class {
    constructor(command, args, options) {
      Object.assign(this, { command, args, options });
    }
  },
};

const originalLoad = Module._load;
Module._load = function load(request, parent, isMain) {
  if (request === 'vscode') {
    return fakeVscode;
  }
  if (request === 'vscode-languageclient/node') {
    return { LanguageClient: FakeLanguageClient };
  }
  return originalLoad.call(this, request, parent, isMain);
};
const extension = require('../extension.js');

beforeEach(() => {
  fake.settings = {};
  fake.commands = {};
  fake.configurationListeners = [];
  fake.errors = [];
  fake.clients = [];
  fake.adapterFactories = {};
  fake.taskProviders = {};
  fake.failStart = undefined;
});

test('the server command defaults to `mpc lsp`', () => {
  assert.deepEqual(extension.serverCommand(undefined, '/work'), { command: 'mpc', args: ['lsp'] });
  assert.deepEqual(extension.serverCommand('  ', '/work'), { command: 'mpc', args: ['lsp'] });
  assert.deepEqual(extension.serverCommand('mpc', undefined), { command: 'mpc', args: ['lsp'] });
});

test('the server path may be absolute, home-relative or workspace-relative', () => {
  const folder = path.join(os.tmpdir(), 'project');
  assert.equal(extension.serverCommand('/opt/mplang/bin/mpc', folder).command, '/opt/mplang/bin/mpc');
  assert.equal(extension.serverCommand('~/bin/mpc', folder).command,
    path.join(os.homedir(), 'bin', 'mpc'));
  assert.equal(extension.serverCommand('.venv/bin/mpc', folder).command,
    path.join(folder, '.venv', 'bin', 'mpc'));
  assert.equal(extension.serverCommand('${workspaceFolder}/.venv/bin/mpc', folder).command,
    path.join(folder, '.venv', 'bin', 'mpc'));
});

test('mplang.server.args are added after `lsp`', () => {
  assert.deepEqual(extension.serverCommand('mpc', undefined, ['--target', 'rs']).args,
    ['lsp', '--target', 'rs']);
  assert.deepEqual(extension.serverCommand('mpc', undefined, 'not a list').args, ['lsp']);
});

test('activate starts `mpc lsp` over stdio for mplang documents', async () => {
  fake.settings['server.path'] = '.venv/bin/mpc';
  fake.settings['server.args'] = ['--target', 'rs'];
  const context = { subscriptions: [] };
  await extension.activate(context);
  assert.equal(fake.clients.length, 1);
  const [client] = fake.clients;
  assert.equal(client.id, 'mplang');
  assert.equal(client.running, true);
  const folder = fake.workspaceFolders[0].uri.fsPath;
  assert.equal(client.serverOptions.command, path.join(folder, '.venv', 'bin', 'mpc'));
  assert.deepEqual(client.serverOptions.args, ['lsp', '--target', 'rs']);
  // Without a transport key the client adds no --stdio argument.
  assert.equal('transport' in client.serverOptions, false);
  assert.equal(client.serverOptions.options.cwd, folder);
  assert.ok(client.clientOptions.documentSelector.some(
    (selector) => selector.language === 'mplang' && selector.scheme === 'file'));
  // the restart command, the `mpc` debug adapter, the `mpc` tasks and the settings listener
  assert.equal(context.subscriptions.length, 4);
  assert.equal(typeof fake.commands['mplang.restartServer'], 'function');
  await extension.deactivate();
  assert.equal(client.stopped, true);
});

test('changing mplang.server restarts the server with the new path', async () => {
  await extension.activate({ subscriptions: [] });
  fake.settings['server.path'] = '/usr/local/bin/mpc';
  const [listener] = fake.configurationListeners;
  await listener({ affectsConfiguration: (section) => section === 'mplang.editor' });
  assert.equal(fake.clients.length, 1);
  await listener({ affectsConfiguration: (section) => section === 'mplang.server' });
  assert.equal(fake.clients.length, 2);
  assert.equal(fake.clients[0].stopped, true);
  assert.equal(fake.clients[1].serverOptions.command, '/usr/local/bin/mpc');
  await fake.commands['mplang.restartServer']();
  assert.equal(fake.clients.length, 3);
  await extension.deactivate();
});

test('a server that cannot start is reported with the setting to fix', async () => {
  fake.settings['server.path'] = 'no-such-mpc';
  fake.failStart = 'spawn no-such-mpc ENOENT';
  await extension.activate({ subscriptions: [] });
  assert.equal(fake.errors.length, 1);
  assert.match(fake.errors[0], /no-such-mpc lsp/);
  assert.match(fake.errors[0], /ENOENT/);
  assert.match(fake.errors[0], /mplang\.server\.path/);
  await extension.deactivate();
});

test('a debug session of type mpc runs `mpc dap` from mplang.server.path', async () => {
  fake.settings['server.path'] = '.venv/bin/mpc';
  fake.settings['server.args'] = ['--target', 'rs'];
  await extension.activate({ subscriptions: [] });
  const factory = fake.adapterFactories.mpc;
  assert.equal(typeof factory.createDebugAdapterDescriptor, 'function');
  const folder = path.join(os.tmpdir(), 'other');
  const adapter = factory.createDebugAdapterDescriptor({ workspaceFolder: { uri: { fsPath: folder } } });
  assert.equal(adapter.command, path.join(folder, '.venv', 'bin', 'mpc'));
  assert.deepEqual(adapter.args, ['dap']);  // the lsp options are not the adapter's
  assert.equal(adapter.options.cwd, folder);
  const fallback = factory.createDebugAdapterDescriptor({});
  assert.equal(fallback.options.cwd, fake.workspaceFolders[0].uri.fsPath);
  assert.deepEqual(extension.adapterCommand(undefined, undefined), { command: 'mpc', args: ['dap'] });
  await extension.deactivate();
});

test('tasks of type mpc run `mpc lint` and `mpc build` with the $mpc problem matcher', async () => {
  fake.settings['server.path'] = '.venv/bin/mpc';
  await extension.activate({ subscriptions: [] });
  const provider = fake.taskProviders.mpc;
  const folder = fake.workspaceFolders[0];
  const mpc = path.join(folder.uri.fsPath, '.venv', 'bin', 'mpc');
  const provided = provider.provideTasks();
  assert.deepEqual(provided.map((task) => [task.name, task.execution.process, task.execution.args]),
    [['lint', mpc, ['lint']], ['build', mpc, ['build']]]);
  for (const task of provided) {
    assert.deepEqual(task.problemMatchers, ['$mpc']);
    assert.equal(task.execution.options.cwd, folder.uri.fsPath);
  }
  assert.equal(provided[1].group, 'build-group');
  const written = { definition: { type: 'mpc', command: 'lint', args: ['src', '--werror'] },
    scope: folder };
  const resolved = provider.resolveTask(written);
  assert.deepEqual(resolved.execution.args, ['lint', 'src', '--werror']);
  assert.equal(resolved.definition, written.definition);  // VS Code requires the same object
  assert.equal(provider.resolveTask({ definition: { type: 'mpc', command: 'flash' } }), undefined);
  assert.equal(extension.taskCommand('mpc', undefined, { command: 'fmt' }), undefined);
  await extension.deactivate();
});
