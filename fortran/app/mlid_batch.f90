!> mlid-batch DECK [--json FILE]: run every case of a deck without Python,
!> as the original batch program did.  A failing case prints one line
!> naming deck, case and problem; the others still run; the exit code is 1
!> if any case failed.
program mlid_batch
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_NOCONV
  use mlid_deck, only: deck_case_t, deck_read, case_record, case_time_input, manoeuvre_layout
  use mlid_api, only: mlid_fit, mlid_simulate
  use mlid_report, only: report_fit, json_open, json_close, json_case
  implicit none
  character(len=1024) :: deck, arg, json_path
  type(deck_case_t), allocatable :: cases(:)
  integer :: status, nfail, k, nargs, ju, njson
  logical :: json
  character(len=256) :: msg
  character(len=:), allocatable :: deck_dir

  nargs = command_argument_count()
  json_path = ''
  deck = ''
  k = 1
  do while (k <= nargs)
    call get_command_argument(k, arg)
    if (arg == '--json' .and. k < nargs) then
      call get_command_argument(k + 1, json_path)
      k = k + 1
    else if (arg == '-h' .or. arg == '--help') then
      write (*, '(a)') 'usage: mlid-batch DECK [--json FILE]', &
        '  runs every case of a namelist deck (jobs: estimate, simulate) and prints the report'
      stop
    else if (arg(1:1) == '-') then
      write (0, '(a)') 'mlid-batch: unknown option '//trim(arg)
      stop 2, quiet=.true.
    else
      deck = arg
    end if
    k = k + 1
  end do
  if (len_trim(deck) == 0) then
    write (0, '(a)') 'usage: mlid-batch DECK [--json FILE]'
    stop 2, quiet=.true.
  end if
  deck_dir = ''
  if (index(deck, '/', back=.true.) > 0) deck_dir = deck(1:index(deck, '/', back=.true.) - 1)

  call deck_read(trim(deck), cases, status, msg)
  if (status /= MLID_OK) then
    write (0, '(a)') 'mlid-batch: '//trim(msg)
    stop 1, quiet=.true.
  end if
  json = .false.
  if (len_trim(json_path) > 0) then
    open (newunit=ju, file=trim(json_path), status='replace', action='write')
    json = .true.
    call json_open(ju)
  end if
  nfail = 0
  njson = 0
  do k = 1, size(cases)
    call run_case(k, cases(k))
  end do
  if (json) then
    call json_close(ju)
    close (ju)
  end if
  if (nfail > 0) then
    write (0, '(i0,a,i0,a)') nfail, ' of ', size(cases), ' cases failed'
    stop 1, quiet=.true.
  end if

contains

  subroutine run_case(k, c)
    integer, intent(in) :: k
    type(deck_case_t), intent(inout) :: c
    real(wp), allocatable :: t(:), u(:, :), y(:, :)
    real(wp), allocatable :: theta(:), theta0(:), sigma(:), cov(:, :), info(:, :), grad(:), eigval(:)
    real(wp), allocatable :: eigvec(:, :)
    real(wp), allocatable :: rhat(:, :), yhat(:, :), hist(:), x(:, :)
    integer, allocatable :: segstart(:)
    real(wp) :: cost, wall
    integer :: niter, reason, converged, bad, nf, nth, cstat, j, t0, t1, rate, ou, rank
    character(len=256) :: cmsg
    character(len=512) :: path
    logical :: fitted

    write (*, '(/,a,i0,a)') ' case ', k, ': '//trim(c%title)
    fitted = .false.
    cstat = c%status
    cmsg = c%msg
    nth = 0
    if (cstat == MLID_OK) nth = size(c%theta)
    nf = 0
    if (cstat == MLID_OK) nf = count(c%isfree == 1)
    if (cstat == MLID_OK .and. c%job == 'simulate') then
      call case_time_input(c, t, u, cstat, cmsg)
      if (cstat == MLID_OK) then
        allocate (y(c%ny, size(t)), x(c%nx, size(t)))
        call mlid_simulate(c%mkind, c%nx, c%nu, c%ny, c%nw, nth, c%theta, size(c%iconst), &
                           c%iconst, size(c%rconst), c%rconst, size(t), t, u, c%seed, 0, &
                           c%iopt, c%ropt, y, x, cstat, cmsg)
      end if
      if (cstat == MLID_OK) then
        path = c%out_file
        if (path(1:1) /= '/' .and. len(deck_dir) > 0) path = deck_dir//'/'//trim(c%out_file)
        open (newunit=ou, file=trim(path), status='replace', action='write', iostat=cstat)
        if (cstat /= 0) then
          cmsg = 'cannot write '//trim(path)
        else
          write (ou, '(a)') '# t, inputs, outputs (mlid simulate)'
          do j = 1, size(t)
            write (ou, '(*(es25.16e3))') t(j), u(:, j), y(:, j)
          end do
          close (ou)
          write (*, '(a,i0,a)') ' simulated ', size(t), ' samples to '//trim(path)
        end if
      end if
    else if (cstat == MLID_OK) then
      call case_record(c, deck_dir, t, u, y, cstat, cmsg, segstart)
      ! several data files: several manoeuvres, each its own x0 and biases
      if (cstat == MLID_OK) call manoeuvre_layout(c, size(segstart), cstat, cmsg)
      if (cstat == MLID_OK) then
        nth = size(c%theta)
        nf = count(c%isfree == 1)
        allocate (theta(nth), theta0(nth), sigma(nth), cov(nf, nf), info(nf, nf), grad(nf), eigval(nf), &
                  eigvec(nf, nf), &
                  rhat(c%ny, c%ny), yhat(c%ny, size(t)), hist(c%iopt(1) + 1))
        call system_clock(t0, rate)
        call mlid_fit(c%mkind, c%nx, c%nu, c%ny, c%nw, nth, c%theta, c%isfree, c%itie, &
                      size(c%iconst), c%iconst, size(c%rconst), c%rconst, size(t), t, u, y, &
                      size(segstart), segstart, c%iopt, c%ropt, nf, size(hist), c%use_prior, prior_or_zero(c%prior, nth), &
                      pweight_or_zero(c%pweight, nf), c%use_bounds, prior_or_zero(c%lower, nth), &
                      prior_or_zero(c%upper, nth), theta0, theta, &
                      sigma, cov, info, grad, eigval, eigvec, rhat, yhat, hist, cost, niter, reason, &
                      converged, rank, bad, cstat, cmsg)
        call system_clock(t1)
        wall = real(t1 - t0, wp)/rate
        if (cstat == MLID_OK .or. cstat == MLID_ERR_NOCONV) then
          call report_fit(6, method_text(c), c%labels, pack(theta0, c%isfree == 1), &
                          pack(theta, c%isfree == 1), pack(sigma, c%isfree == 1), cost, rhat, &
                          niter, reason, converged == 1, rank, c%iopt(10), eigval, eigvec, cov)
          fitted = .true.
        end if
        if (cstat /= MLID_OK .and. bad > 0) cmsg = replace_index(cmsg, bad, c%labels)
        if (cstat == MLID_OK .and. cmsg(1:8) == 'warning:') write (0, '(a,i0,a,i0,a)') &
          'mlid-batch: '//trim(deck)//' case ', k, ' (line ', c%line, ') '''//trim(c%title)// &
          ''': '//trim(cmsg)
      end if
    end if
    if (json) then
      if (fitted) then
        call json_case(ju, njson == 0, c%title, c%job, cstat, cmsg, c%labels, &
                       pack(theta, c%isfree == 1), pack(sigma, c%isfree == 1), cost, rhat, &
                       niter, converged == 1, wall)
      else
        call json_case(ju, njson == 0, c%title, c%job, cstat, cmsg, [character(len=1) ::], &
                       [real(wp) ::], [real(wp) ::], 0.0_wp, reshape([real(wp) ::], [0, 0]), &
                       0, .false., 0.0_wp)
      end if
      njson = njson + 1
    end if
    if (cstat /= MLID_OK) then
      nfail = nfail + 1
      write (0, '(a,i0,a,i0,a)') 'mlid-batch: '//trim(deck)//' case ', k, ' (line ', c%line, &
        ') '''//trim(c%title)//''': '//trim(cmsg)
      write (*, '(a)') ' FAILED: '//trim(cmsg)
    end if
  end subroutine run_case

  !> An optional array, or zeros of the size the interface wants.
  function prior_or_zero(a, n) result(out)
    real(wp), allocatable, intent(in) :: a(:)
    integer, intent(in) :: n
    real(wp) :: out(n)
    out = 0.0_wp
    if (allocated(a)) out = a
  end function prior_or_zero

  function pweight_or_zero(a, n) result(out)
    real(wp), allocatable, intent(in) :: a(:, :)
    integer, intent(in) :: n
    real(wp) :: out(n, n)
    out = 0.0_wp
    if (allocated(a)) out = a
  end function pweight_or_zero

  !> The estimator, as the report's first line names it.
  function method_text(c) result(text)
    type(deck_case_t), intent(in) :: c
    character(len=:), allocatable :: text
    if (c%method == 'filter_error') then
      text = 'filter-error ML, '//trim(merge('steady-state gain', 'time-varying gain', &
             c%iopt(8) == 1))//', '//trim(merge('with gain partials   ', 'without gain partials', &
             c%iopt(7) == 1))
    else
      text = 'output-error ML, R '//trim(c%noise)
    end if
  end function method_text

  !> Put the name of free parameter bad in place of "free parameter <bad>".
  function replace_index(text, bad, labels) result(out)
    character(len=*), intent(in) :: text
    integer, intent(in) :: bad
    character(len=*), intent(in) :: labels(:)
    character(len=256) :: out
    character(len=32) :: key
    integer :: p, e
    write (key, '(a,i0)') 'free parameter ', bad
    p = index(text, trim(key))
    out = text
    if (p == 0) return
    e = p + len_trim(key)
    if (e <= len(text)) then
      if (index('0123456789', text(e:e)) > 0) return
    end if
    out = text(1:p - 1)//''''//trim(labels(bad))//''''//text(e:)
  end function replace_index

end program mlid_batch
