'use strict';
// The mplang extension: highlighting and folding come from the grammar and the language
// configuration; this file only starts `mpc lsp` (the compiler's own checks, hover,
// completion, definitions) over stdio and restarts it when its settings change, and runs
// `mpc dap` (the same executable) for debug sessions of type `mpc` (docs/debug.md), and
// provides tasks of type `mpc` (`mpc lint`, `mpc build`) whose output the `$mpc` problem
// matcher of package.json turns into the Problems panel (docs/editors.md).

const os = require('os');
const path = require('path');
const vscode = require('vscode');
const { LanguageClient } = require('vscode-languageclient/node');

const SECTION = 'mplang';
const PATH_SETTING = 'server.path';
const ARGS_SETTING = 'server.args';

/** @type {LanguageClient | undefined} */
let client;

/**
 * The command that runs the server, from the `mplang.server.path` setting (a name looked up
 * on PATH, an absolute path, or a path relative to the first workspace folder) and the
 * options of `mplang.server.args`.
 * @param {string | undefined} setting
 * @param {string | undefined} workspaceFolder
 * @param {unknown} extraArgs
 * @returns {{command: string, args: string[]}}
 */
function serverCommand(setting, workspaceFolder, extraArgs) {
  let command = (setting || '').trim() || 'mpc';
  if (command === '~' || command.startsWith('~/') || command.startsWith('~\\')) {
    command = path.join(os.homedir(), command.slice(1));
  }
  if (workspaceFolder !== undefined) {
    command = command.split('${workspaceFolder}').join(workspaceFolder);
    const hasDirectory = command.includes('/') || command.includes(path.sep);
    if (hasDirectory && !path.isAbsolute(command)) {
      command = path.resolve(workspaceFolder, command);
    }
  }
  const options = Array.isArray(extraArgs) ? extraArgs.map(String) : [];
  return { command, args: ['lsp', ...options] };
}

/**
 * The debug adapter of a `mpc` debug session: `mpc dap` from the same `mplang.server.path`
 * as the language server, started in the session's folder (launch paths are relative to it).
 * @param {string | undefined} setting
 * @param {string | undefined} workspaceFolder
 * @returns {{command: string, args: string[]}}
 */
function adapterCommand(setting, workspaceFolder) {
  return { command: serverCommand(setting, workspaceFolder, []).command, args: ['dap'] };
}

const debugAdapterFactory = {
  /** @param {import('vscode').DebugSession} session */
  createDebugAdapterDescriptor(session) {
    const folder = session.workspaceFolder ? session.workspaceFolder.uri.fsPath
      : firstWorkspaceFolder();
    const configuration = vscode.workspace.getConfiguration(SECTION);
    const { command, args } = adapterCommand(configuration.get(PATH_SETTING), folder);
    return new vscode.DebugAdapterExecutable(command, args, folder ? { cwd: folder } : {});
  },
};

const TASK_COMMANDS = ['lint', 'build'];

/**
 * The command line of an `mpc` task: `mpc lint|build ARGS...`, with the mpc executable of
 * `mplang.server.path`. Undefined for a command the task type does not have.
 * @param {string | undefined} setting
 * @param {string | undefined} workspaceFolder
 * @param {{command?: unknown, args?: unknown}} definition
 * @returns {{command: string, args: string[]} | undefined}
 */
function taskCommand(setting, workspaceFolder, definition) {
  if (typeof definition.command !== 'string' || !TASK_COMMANDS.includes(definition.command)) {
    return undefined;
  }
  const options = Array.isArray(definition.args) ? definition.args.map(String) : [];
  const { command } = serverCommand(setting, workspaceFolder, []);
  return { command, args: [definition.command, ...options] };
}

/**
 * A task that runs `definition` in `folder` and reads its output with `$mpc`.
 * @param {{type: string, command?: unknown, args?: unknown}} definition
 * @param {import('vscode').WorkspaceFolder} folder
 */
function mpcTask(definition, folder) {
  const configuration = vscode.workspace.getConfiguration(SECTION);
  const line = taskCommand(configuration.get(PATH_SETTING), folder.uri.fsPath, definition);
  if (line === undefined) {
    return undefined;
  }
  const execution = new vscode.ProcessExecution(line.command, line.args,
    { cwd: folder.uri.fsPath });
  const task = new vscode.Task(definition, folder, line.args.join(' '), 'mpc', execution,
    ['$mpc']);
  if (definition.command === 'build') {
    task.group = vscode.TaskGroup.Build;
  }
  return task;
}

const taskProvider = {
  /** `mpc lint` and `mpc build` of each workspace folder (its mpc.toml says what). */
  provideTasks() {
    const folders = vscode.workspace.workspaceFolders || [];
    return folders.flatMap((folder) => TASK_COMMANDS.map(
      (command) => mpcTask({ type: 'mpc', command }, folder)));
  },
  /** A task of tasks.json: `{"type": "mpc", "command": "lint", "args": [...]}`. */
  resolveTask(task) {
    const folders = vscode.workspace.workspaceFolders || [];
    const folder = task.scope && task.scope.uri ? task.scope : folders[0];
    return folder === undefined ? undefined : mpcTask(task.definition, folder);
  },
};

function firstWorkspaceFolder() {
  const folders = vscode.workspace.workspaceFolders;
  return folders && folders.length > 0 ? folders[0].uri.fsPath : undefined;
}

async function startClient() {
  const configuration = vscode.workspace.getConfiguration(SECTION);
  const workspaceFolder = firstWorkspaceFolder();
  const { command, args } = serverCommand(
    configuration.get(PATH_SETTING), workspaceFolder, configuration.get(ARGS_SETTING));
  // No `transport` key: the client then talks over the process's stdin/stdout without
  // adding a `--stdio` argument that `mpc lsp` does not take.
  const serverOptions = { command, args, options: { cwd: workspaceFolder } };
  const clientOptions = {
    documentSelector: [
      { scheme: 'file', language: 'mplang' },
      { scheme: 'untitled', language: 'mplang' },
    ],
    outputChannelName: 'mplang',
  };
  const started = new LanguageClient(SECTION, 'mplang (mpc lsp)', serverOptions, clientOptions);
  client = started;
  try {
    await started.start();
  } catch (error) {
    client = undefined;
    const reason = error instanceof Error ? error.message : String(error);
    vscode.window.showErrorMessage(
      `mplang: cannot start "${command} ${args.join(' ')}" (${reason}). ` +
        'Install mplang (pip install .) or set "mplang.server.path" to the mpc executable, ' +
        'for example .venv/bin/mpc.',
    );
  }
}

async function stopClient() {
  const running = client;
  client = undefined;
  // A client whose start failed or whose server gave up has nothing to shut down.
  if (running !== undefined && running.isRunning()) {
    await running.stop();
  }
}

async function restartClient() {
  await stopClient();
  await startClient();
}

/** @param {import('vscode').ExtensionContext} context */
async function activate(context) {
  context.subscriptions.push(
    vscode.commands.registerCommand('mplang.restartServer', restartClient),
    vscode.debug.registerDebugAdapterDescriptorFactory('mpc', debugAdapterFactory),
    vscode.tasks.registerTaskProvider('mpc', taskProvider),
    vscode.workspace.onDidChangeConfiguration((event) => {
      if (event.affectsConfiguration(`${SECTION}.server`)) {
        return restartClient();
      }
      return undefined;
    }),
  );
  await startClient();
}

function deactivate() {
  return stopClient();
}

module.exports = { activate, adapterCommand, deactivate, serverCommand, taskCommand,
  taskProvider };
