function out = zwidth_request(method, path, body, opts)
%ZWIDTH_REQUEST  Send one request to the zwidth service and decode its JSON answer.
%
%   out = zwidth_request('GET', '/v1/presets')
%   out = zwidth_request('POST', '/v1/analysis/stability', struct('device', dev), opts)
%
%   BODY is a struct encoded with jsonencode ([] or '' for none).  OUT is the
%   answer decoded with jsondecode (SI units, the field names of the HTTP API).
%
%   OPTS (struct, every field optional):
%     url        service URL (default: getenv('ZWIDTH_URL'), else http://127.0.0.1:8000)
%     token      bearer token (default: getenv('ZWIDTH_API_TOKEN'); none when empty)
%     timeout    seconds to wait for the answer (default 60; the service's own budget is 30 s)
%     attempts   tries in all while the connection is refused (default 3)
%     transport  'auto' (default), 'web', 'curl', or a function handle
%                resp = f(req) with req.method, req.url, req.headers (n-by-2 cell),
%                req.body (JSON text), req.timeout and resp.status, resp.body (text)
%
%   Transports: 'web' uses webwrite/webread with weboptions (MATLAB).  GNU Octave's
%   webwrite (7.x) cannot send a JSON body -- it form-encodes its DATA argument
%   and drops a lone string -- so under Octave 'auto' uses the curl program for
%   every request instead ('web' still works there for GET).
%
%   Errors (identifiers):
%     zwidth:validation  422: the message names each rejected field, e.g. "device.mass: ..."
%     zwidth:api         any other status >= 400 (401 token, 413 too large, 503 budget ...)
%     zwidth:transport   no answer (connection refused after the retries, timeout)
%
%   See also ZWIDTH_ANALYZE, ZWIDTH_BOUNDARY, ZWIDTH_DESIGN_STIFFNESS.

  if nargin < 3, body = []; end
  if nargin < 4, opts = struct(); end
  url = option(opts, 'url', getenv('ZWIDTH_URL'));
  if isempty(url), url = 'http://127.0.0.1:8000'; end
  token = option(opts, 'token', getenv('ZWIDTH_API_TOKEN'));

  req.method = upper(method);
  req.url = [regexprep(url, '/+$', ''), path];
  req.headers = {'Accept', 'application/json'};
  if ~isempty(token)
    req.headers(end+1, :) = {'Authorization', ['Bearer ', token]};
  end
  req.body = '';
  if ~isempty(body)
    req.body = jsonencode(body);
    req.headers(end+1, :) = {'Content-Type', 'application/json'};
  end
  req.timeout = option(opts, 'timeout', 60);
  attempts = option(opts, 'attempts', 3);

  transport = option(opts, 'transport', 'auto');
  if ischar(transport)
    if strcmp(transport, 'auto')
      if exist('OCTAVE_VERSION', 'builtin'), transport = 'curl'; else, transport = 'web'; end
    end
    switch transport
      case 'web', transport = @web_transport;
      case 'curl', transport = @curl_transport;
      otherwise, error('zwidth:usage', 'zwidth_request: unknown transport ''%s''', transport);
    end
  end

  % Retry only while the connection is refused: the request never reached the service.
  for attempt = 1:attempts
    resp = transport(req);
    if ~(isfield(resp, 'refused') && resp.refused) || attempt == attempts, break; end
    pause(0.2 * 2^(attempt - 1));
  end
  if isfield(resp, 'refused') && resp.refused
    error('zwidth:transport', 'zwidth: no answer from %s %s: %s (after %d attempts)', ...
          req.method, req.url, resp.message, attempts);
  end
  if resp.status == 0
    error('zwidth:transport', 'zwidth: no answer from %s %s: %s', req.method, req.url, resp.message);
  end
  if resp.status >= 400
    raise_api_error(req, resp);
  end
  if isempty(resp.body)
    out = [];
  else
    out = jsondecode(resp.body);
  end
end

function value = option(opts, name, default)
  if isfield(opts, name) && ~isempty(opts.(name))
    value = opts.(name);
  else
    value = default;
  end
end

function raise_api_error(req, resp)
  detail = resp.body;
  try
    decoded = jsondecode(resp.body);
    if isfield(decoded, 'detail'), detail = decoded.detail; end
  catch
  end
  if resp.status == 422 && (isstruct(detail) || iscell(detail))
    lines = {};
    for i = 1:numel(detail)
      if iscell(detail), e = detail{i}; else, e = detail(i); end
      loc = e.loc;
      if ~iscell(loc), loc = num2cell(loc); end
      parts = cellfun(@num2str, loc, 'UniformOutput', false);
      if ~isempty(parts) && any(strcmp(parts{1}, {'body', 'query'})), parts = parts(2:end); end
      lines{end+1} = sprintf('%s: %s', strjoin(parts, '.'), e.msg); %#ok<AGROW>
    end
    error('zwidth:validation', 'zwidth: invalid request (422) to %s: %s', req.url, strjoin(lines, '; '));
  end
  if ~ischar(detail), detail = jsonencode(detail); end
  id = 'zwidth:api';
  if resp.status == 422, id = 'zwidth:validation'; end
  error(id, 'zwidth: %d from %s %s: %s', resp.status, req.method, req.url, detail);
end

function resp = web_transport(req)
  % MATLAB's webwrite sends a char DATA with MediaType application/json as the raw body.
  headers = req.headers(~strcmpi(req.headers(:, 1), 'Content-Type') & ~strcmpi(req.headers(:, 1), 'Accept'), :);
  o = weboptions('Timeout', req.timeout, 'ContentType', 'text', 'MediaType', 'application/json');
  if ~isempty(headers), o.HeaderFields = headers; end
  resp = struct('status', 200, 'body', '', 'message', '', 'refused', false);
  try
    if strcmp(req.method, 'GET')
      resp.body = webread(req.url, o);
    else
      resp.body = webwrite(req.url, req.body, o);
    end
  catch e
    % webread/webwrite keep the status in the message only ("... status 422 ...").
    tok = regexp(e.message, '(?:status|code)\D{0,20}(\d{3})', 'tokens', 'once');
    if ~isempty(tok)
      resp.status = str2double(tok{1});
      resp.body = e.message;
    else
      resp.status = 0;
      resp.message = e.message;
      resp.refused = ~isempty(regexpi(e.message, 'refused|could not connect|couldn''t connect', 'once'));
    end
  end
end

function resp = curl_transport(req)
  resp = struct('status', 0, 'body', '', 'message', '', 'refused', false);
  bodyfile = [tempname(), '.json'];
  outfile = [tempname(), '.out'];
  cleanup = onCleanup(@() delete_files({bodyfile, outfile}));
  args = {'curl', '-sS', '-X', req.method, '--connect-timeout', '5', '--max-time', sprintf('%g', req.timeout), ...
          '-o', outfile, '-w', '%{http_code}'};
  for i = 1:size(req.headers, 1)
    args(end+1:end+2) = {'-H', sprintf('%s: %s', req.headers{i, 1}, req.headers{i, 2})};
  end
  if ~isempty(req.body)
    fid = fopen(bodyfile, 'w');
    fwrite(fid, req.body, 'char');
    fclose(fid);
    args(end+1:end+2) = {'--data-binary', ['@', bodyfile]};
  end
  args{end+1} = req.url;
  [code, text] = system(strjoin(cellfun(@shell_quote, args, 'UniformOutput', false), ' '));
  if code ~= 0
    resp.message = strtrim(text);
    resp.refused = (code == 7);   % curl: "Failed to connect" (refused, nothing listening)
    return;
  end
  resp.status = str2double(strtrim(text));
  fid = fopen(outfile, 'r');
  if fid >= 0
    resp.body = fread(fid, Inf, '*char')';
    fclose(fid);
  end
end

function q = shell_quote(s)
  q = ['''', strrep(s, '''', '''\'''''), ''''];
end

function delete_files(names)
  for i = 1:numel(names)
    if exist(names{i}, 'file'), delete(names{i}); end
  end
end
