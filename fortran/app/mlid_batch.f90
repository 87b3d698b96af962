!> mlid-batch DECK... [--json FILE]: run every case of the decks, one deck
!> after another, without Python, as the original batch program did.  A
!> failing case prints one line naming deck, case and problem; the others
!> still run; so do the other decks when one cannot be read; the exit code
!> is 1 if any case failed or any deck could not be read.  Records and the
!> JSON file are written whole or not at all: to a temporary name in the
!> same folder, renamed when complete.
program mlid_batch
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use, intrinsic :: iso_c_binding, only: c_int, c_intptr_t
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_NOCONV, fit_outcome, FIT_ESTIMATES, &
                        FIT_FAILED, FIT_NOT_RUN
  use mlid_case, only: case_t
  use mlid_text, only: line_t, join_lines
  use mlid_deck, only: deck_read, case_record, manoeuvre_layout, &
                       case_param_units, holdout_case, manoeuvre_block, corrected_writable, &
                       NAMELEN
  use mlid_units, only: UNITLEN
  use mlid_validate, only: prediction_stats
  use mlid_api, only: mlid_fit, mlid_simulate, mlid_flightpath_corrected
  use mlid_jobs, only: job_run, JOB_RUNS
  use mlid_files, only: temporary_for, write_whole, same_file
  use mlid_report, only: fit_summary_t, fit_report, fit_json, case_json, json_list, &
                         validation_report, validation_json
  use mlid_wait_policy, only: brief_spin
  implicit none
  character(len=4096) :: deck, arg, json_path
  type(case_t), allocatable :: cases(:)
  integer :: status, nfail, k, nargs, ndeck, nunread, ncases, d
  character(len=256) :: msg
  character(len=:), allocatable :: objects, json_tmp
  logical, allocatable :: is_deck(:)

  call brief_spin()
  call ignore_file_size_signal()
  nargs = command_argument_count()
  allocate (is_deck(nargs), source=.false.)
  json_path = ''
  k = 1
  do while (k <= nargs)
    call get_command_argument(k, arg)
    if (arg == '--json') then
      if (k == nargs) then
        write (0, '(a)') 'mlid-batch: --json needs a file name'
        stop 2, quiet=.true.
      end if
      call get_command_argument(k + 1, json_path)
      k = k + 1
    else if (arg(1:7) == '--json=') then       ! as Python's argparse takes it
      json_path = arg(8:)
    else if (arg == '-h' .or. arg == '--help') then
      write (*, '(a)') 'usage: mlid-batch DECK... [--json FILE]', &
        '  runs every case of the namelist decks, one deck after another (jobs: estimate, '// &
        'validate, simulate, design, monte_carlo), and prints the report'
      stop
    else if (arg(1:1) == '-') then
      write (0, '(a)') 'mlid-batch: unknown option '//trim(arg)
      stop 2, quiet=.true.
    else
      is_deck(k) = .true.
    end if
    k = k + 1
  end do
  ndeck = count(is_deck)
  if (ndeck == 0) then
    write (0, '(a)') 'usage: mlid-batch DECK... [--json FILE]'
    stop 2, quiet=.true.
  end if
  ! the JSON destination is tried before any case runs, and may not be a deck
  if (len_trim(json_path) > 0) then
    do d = 1, nargs
      call get_command_argument(d, deck)
      if (is_deck(d) .and. same_file(json_path, deck)) then
        write (0, '(a)') 'mlid-batch: cannot write --json '//trim(json_path)// &
          ' (a deck this run reads)'
        stop 1, quiet=.true.
      end if
    end do
    call temporary_for(trim(json_path), json_tmp, status, msg, '--json')
    if (status /= MLID_OK) then
      write (0, '(a)') 'mlid-batch: '//trim(msg)
      stop 1, quiet=.true.
    end if
  end if

  nfail = 0
  nunread = 0
  ncases = 0
  objects = ''
  do d = 1, nargs
    if (.not. is_deck(d)) cycle
    call get_command_argument(d, deck)
    call deck_read(trim(deck), cases, status, msg)
    if (status /= MLID_OK) then
      write (0, '(a)') 'mlid-batch: '//trim(msg)
      if (ndeck == 1) stop 1, quiet=.true.
      nunread = nunread + 1
      cycle
    end if
    do k = 1, size(cases)
      call run_case(k, cases(k))
    end do
    ncases = ncases + size(cases)
  end do
  if (nfail > 0) write (0, '(i0,a,i0,a)') nfail, ' of ', ncases, ' cases failed'
  if (nunread > 0) write (0, '(i0,a,i0,a)') nunread, ' of ', ndeck, ' decks could not be read'
  if (len_trim(json_path) > 0) then
    call write_whole(trim(json_path), json_tmp, json_list(objects, ncases), status, msg)
    if (status /= MLID_OK) then
      write (0, '(a)') 'mlid-batch: '//trim(msg)
      stop 1, quiet=.true.
    end if
  end if
  if (nfail > 0 .or. nunread > 0) stop 1, quiet=.true.

contains

  !> A file over the size limit (ulimit -f) is then a failed write, which the
  !> writers report in one line and clean up after, as Python's front end
  !> does, not a signal that kills the run (the runtime's handler prints a
  !> backtrace).  Linux's numbers: SIGXFSZ 25, SIG_IGN 1.
  subroutine ignore_file_size_signal()
    interface
      function c_signal(signum, handler) bind(c, name='signal') result(previous)
        import :: c_int, c_intptr_t
        integer(c_int), value :: signum
        integer(c_intptr_t), value :: handler
        integer(c_intptr_t) :: previous
      end function c_signal
    end interface
    integer(c_intptr_t) :: previous
    previous = c_signal(25_c_int, 1_c_intptr_t)
  end subroutine ignore_file_size_signal

  !> Run case k: print its report, add its JSON object, count a failure.
  subroutine run_case(k, c)
    integer, intent(in) :: k
    type(case_t), intent(inout) :: c
    character(len=:), allocatable :: json
    integer :: cstat, outcome
    character(len=256) :: cmsg

    write (*, '(/,a,i0,a)') ' case ', k, ': '//trim(c%title)
    cstat = c%status
    cmsg = c%msg
    outcome = FIT_NOT_RUN
    if (cstat /= MLID_OK) then
      json = case_json(c%title, c%job, cstat, cmsg)
    else if (index(JOB_RUNS, ' '//trim(c%job)//' ') > 0) then
      call job_case(c, json, cstat, cmsg)
    else if (c%job == 'validate') then
      call validate_case(k, c, json, cstat, cmsg, outcome)
    else
      call fit_case(k, c, json, cstat, cmsg, outcome)
    end if
    ! a job that stopped before its result has only its message to give
    if (.not. allocated(json)) json = case_json(c%title, c%job, cstat, cmsg)
    if (len(objects) > 0) objects = objects//','//achar(10)
    objects = objects//json
    if (cstat /= MLID_OK) then
      nfail = nfail + 1
      call say(k, c, cmsg)
      ! a failed fit's report ends with this line already
      if (outcome /= FIT_FAILED) write (*, '(a)') ' FAILED: '//trim(cmsg)
    end if
  end subroutine run_case

  !> A line on stderr about case k: a failure or a warning.
  subroutine say(k, c, text)
    integer, intent(in) :: k
    type(case_t), intent(in) :: c
    character(len=*), intent(in) :: text
    write (0, '(a,i0,a,i0,a)') 'mlid-batch: '//trim(deck)//' case ', k, ' (line ', c%line, &
      ') '''//trim(c%title)//''': '//trim(text)
  end subroutine say

  !> The warnings of the records read for case k, one line each.
  subroutine say_notes(k, c, notes)
    integer, intent(in) :: k
    type(case_t), intent(in) :: c
    type(line_t), intent(in) :: notes(:)
    integer :: j
    do j = 1, size(notes)
      call say(k, c, notes(j)%s)
    end do
  end subroutine say_notes

  !> A job run whole in the core (mlid_jobs: simulate, design,
  !> monte_carlo), its report printed as Python prints it.
  subroutine job_case(c, json, cstat, cmsg)
    type(case_t), intent(in) :: c
    character(len=:), allocatable, intent(out) :: json
    integer, intent(out) :: cstat
    character(len=*), intent(out) :: cmsg
    character(len=:), allocatable :: report, text
    call job_run(c, report, text, cstat, cmsg)
    if (cstat /= MLID_OK) return
    write (*, '(a)', advance='no') report
    json = text
  end subroutine job_case

  !> Fit an estimate case and write its corrected records.  A fit that did
  !> not converge is a result with a warning, not a failure of the case.
  subroutine fit_case(k, c, json, cstat, cmsg, outcome)
    integer, intent(in) :: k
    type(case_t), intent(inout) :: c
    character(len=:), allocatable, intent(out) :: json
    integer, intent(out) :: cstat
    character(len=*), intent(out) :: cmsg
    integer, intent(out) :: outcome       !< of the fit (mlid_kinds FIT_*)
    real(wp), allocatable :: t(:), u(:, :), y(:, :), theta(:), rhat(:, :), yhat(:, :), own_t(:)
    integer, allocatable :: segstart(:)
    character(len=UNITLEN), allocatable :: units(:)
    type(line_t), allocatable :: notes(:)

    outcome = FIT_NOT_RUN
    call case_record(c, t, u, y, cstat, cmsg, segstart, units, notes=notes, own_t=own_t)
    if (allocated(notes)) call say_notes(k, c, notes)
    if (cstat == MLID_OK) call corrected_writable(c, cstat, cmsg)   ! before a long fit
    if (cstat == MLID_OK) call fit_record(k, c, t, u, y, segstart, units, .true., json, cstat, &
                                          cmsg, theta, rhat, yhat, outcome)
    if (allocated(c%corrected)) then
      if (cstat == MLID_OK) then
        call write_corrected(c, own_t, u, y, segstart, units, theta, cstat, cmsg)
        if (cstat /= MLID_OK) deallocate (json)   ! the case failed: its message, not the fit's
      else if (outcome == FIT_ESTIMATES) then     ! not converged, reported
        write (*, '(a)') ' corrected records not written: the fit did not end well'
      end if
    end if
    if (cstat == MLID_ERR_NOCONV .and. outcome == FIT_ESTIMATES) then
      call say(k, c, 'warning: '//cmsg)
      cstat = MLID_OK
    end if
  end subroutine fit_case

  !> Each manoeuvre's record with the fit's corrections undone, written
  !> where &estimate corrected says (mlid_api's mlid_flightpath_corrected,
  !> as the Python front end writes it), its channels named as the model
  !> names its inputs and outputs.
  subroutine write_corrected(c, t, u, y, segstart, units, theta, cstat, cmsg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: t(:)                !< each manoeuvre's own time (its file's)
    real(wp), intent(in) :: u(:, :), y(:, :), theta(:)
    integer, intent(in) :: segstart(:)
    character(len=*), allocatable, intent(in) :: units(:)
    integer, intent(out) :: cstat
    character(len=*), intent(out) :: cmsg
    real(wp), allocatable :: p(:), bias(:), delay(:), udelay(:), uc(:, :), yc(:, :)
    character(len=NAMELEN), allocatable :: names(:)
    integer :: j, j0, j1, n
    character(len=256) :: msg

    names = [c%input_names, c%output_names]

    do j = 1, size(segstart)
      j0 = segstart(j)
      j1 = size(t)
      if (j < size(segstart)) j1 = segstart(j + 1) - 1
      n = j1 - j0 + 1
      p = manoeuvre_block(c, size(segstart), theta, j, 'p')
      bias = manoeuvre_block(c, size(segstart), theta, j, 'bias')
      delay = manoeuvre_block(c, size(segstart), theta, j, 'delay')
      udelay = manoeuvre_block(c, size(segstart), theta, j, 'udelay')
      allocate (uc(c%nu, n), yc(c%ny, n))
      call mlid_flightpath_corrected(size(c%iconst), c%iconst, size(p), p, c%ny, bias, delay, &
                                     c%nu, udelay, n, t(j0:j1), u(:, j0:j1), y(:, j0:j1), &
                                     join_lines(names), &
                                     join_lines(units), trim(c%corrected(j)), &
                                     uc, yc, cstat, msg)
      cmsg = msg
      if (cstat /= MLID_OK) return
      write (*, '(a,i0,a)') ' corrected record of manoeuvre ', j, ' written to '// &
        trim(c%corrected(j))
      deallocate (uc, yc)
    end do
  end subroutine write_corrected

  !> Fit case c to a record (several manoeuvres: segstart), print the
  !> report if asked, and return the JSON object, theta, R-hat and outputs.
  subroutine fit_record(k, c, t, u, y, segstart, units, report, json, cstat, cmsg, theta, &
                        rhat, yhat, outcome)
    integer, intent(in) :: k
    type(case_t), intent(inout) :: c
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    integer, intent(in) :: segstart(:)
    character(len=*), intent(in) :: units(:)
    logical, intent(in) :: report
    character(len=:), allocatable, intent(out) :: json
    integer, intent(out) :: cstat
    character(len=*), intent(out) :: cmsg
    real(wp), allocatable, intent(out) :: theta(:), rhat(:, :), yhat(:, :)
    integer, intent(out) :: outcome       !< of the fit (mlid_kinds FIT_*)
    real(wp), allocatable :: theta0(:), sigma(:), grad(:), sigc(:), hist(:), info(:, :), covc(:, :)
    real(wp), allocatable :: rnoise(:)
    type(fit_summary_t) :: s
    integer :: bad, nf, nth, converged
    logical, allocatable :: free(:)

    outcome = FIT_NOT_RUN
    call case_param_units(c, size(segstart), units, s%units, cstat, cmsg)
    ! several data files: several manoeuvres, each its own x0 and biases
    if (cstat == MLID_OK) call manoeuvre_layout(c, size(segstart), cstat, cmsg)
    if (cstat /= MLID_OK) return
    nth = size(c%theta)
    nf = count(c%isfree == 1)
    allocate (theta(nth), theta0(nth), sigma(nth), sigc(nth), grad(nf), info(nf, nf), rhat(c%ny, c%ny), &
              yhat(c%ny, size(t)), hist(c%iopt(1) + 1), s%cov(nf, nf), s%eigval(nf), &
              s%eigvec(nf, nf), covc(nf, nf), rnoise(c%ny))
    call mlid_fit(c%mkind, c%nx, c%nu, c%ny, c%nw, nth, c%theta, c%isfree, size(c%tie%to), &
                  size(c%tie%to), c%tie%to, c%tie%from, c%tie%scale, c%tie%offset, &
                  size(c%iconst), c%iconst, size(c%rconst), c%rconst, size(t), t, u, y, &
                  size(segstart), segstart, c%iopt, c%ropt, nf, size(hist), c%use_prior, &
                  or_zero(c%prior, nth), weight_or_zero(c%pweight, nf), c%use_bounds, &
                  or_zero(c%lower, nth), or_zero(c%upper, nth), theta0, theta, sigma, s%cov, &
                  info, grad, s%eigval, s%eigvec, rhat, yhat, hist, s%cost, s%niter, s%reason, &
                  converged, s%rank, bad, sigc, covc, s%lag, rnoise, cstat, cmsg)
    if (cstat /= MLID_OK .and. bad > 0) cmsg = replace_index(cmsg, bad, c%labels)
    ! a fit that ran has a report: its estimates, or its last values if it failed
    outcome = fit_outcome(cstat, s%reason)
    if (outcome == FIT_NOT_RUN .or. .not. report) return
    free = c%isfree == 1
    s%labels = c%labels
    s%start = pack(theta0, free)
    s%est = pack(theta, free)
    s%sig = pack(sigma, free)
    s%sigc = pack(sigc, free)
    s%rhat = rhat
    if (all(ieee_is_finite(rnoise))) s%rnoise = rnoise
    s%hist = hist(1:s%niter + 1)
    s%converged = converged == 1
    write (*, '(a)', advance='no') fit_report(s, c%iopt, c%ropt, cstat, cmsg)
    json = fit_json(c%title, c%job, cstat, cmsg, s, c%iopt, c%ropt)
    if (cstat == MLID_OK .and. cmsg(1:min(8, len(cmsg))) == 'warning:') call say(k, c, cmsg)
  end subroutine fit_record

  !> Validate case c: fit on the files not held out (reported as an estimate
  !> case is), then predict the held-out ones (holdout_case) and say how well.
  subroutine validate_case(k, c, json, cstat, cmsg, outcome)
    integer, intent(in) :: k
    type(case_t), intent(inout) :: c
    character(len=:), allocatable, intent(out) :: json
    integer, intent(out) :: cstat
    character(len=*), intent(out) :: cmsg
    integer, intent(out) :: outcome       !< of the fit (mlid_kinds FIT_*)
    real(wp), allocatable :: t(:), u(:, :), y(:, :), theta(:), rhat(:, :), yhat(:, :), r0(:, :)
    real(wp), allocatable :: th(:), uh(:, :), yh(:, :), pred(:, :), theil(:), rms(:), ratio(:)
    integer, allocatable :: segstart(:), sh(:)
    character(len=UNITLEN), allocatable :: units(:), hunits(:)
    character(len=NAMELEN), allocatable :: names(:)
    type(line_t), allocatable :: notes(:)
    character(len=:), allocatable :: hjson
    type(case_t) :: fitted, held
    logical, allocatable :: out(:)
    integer :: held_outcome

    outcome = FIT_NOT_RUN
    allocate (out(size(c%data_files)))
    out = .false.
    out(c%holdout) = .true.
    ! each part read and joined as the Python front end joins its records; all
    ! read before the fit, as the Python front end reads them
    fitted = files_of(c, .not. out)
    call case_record(fitted, t, u, y, cstat, cmsg, segstart, units, notes=notes)
    if (allocated(notes)) call say_notes(k, c, notes)
    if (cstat == MLID_OK) call case_record(files_of(c, out), th, uh, yh, cstat, cmsg, sh, &
                                           hunits, names, notes)
    if (cstat == MLID_OK) call say_notes(k, c, notes)
    if (cstat == MLID_OK) call fit_record(k, fitted, t, u, y, segstart, units, .true., json, &
                                          cstat, cmsg, theta, rhat, yhat, outcome)
    if (cstat /= MLID_OK) return
    call holdout_case(files_of(c, out), theta, count(.not. out), held, cstat, cmsg)
    if (cstat /= MLID_OK) return
    if (count(held%isfree == 1) > 0) then
      call fit_record(k, held, th, uh, yh, sh, hunits, .false., hjson, cstat, cmsg, theta, r0, &
                      pred, held_outcome)
    else
      call predict(held, th, uh, sh, pred, cstat, cmsg)
    end if
    if (cstat /= MLID_OK) then         ! the case failed: its JSON says why, not the fit's
      cmsg = 'prediction of the held-out files: '//trim(cmsg)
      deallocate (json)
      return
    end if
    allocate (theil(c%ny), rms(c%ny), ratio(c%ny))
    call prediction_stats(yh, pred, rhat, theil, rms, ratio)
    if (allocated(c%output_names)) then
      if (all(len_trim(c%output_names) > 0)) names(c%nu + 1:) = c%output_names
    end if
    write (*, '(a)', advance='no') validation_report(names(c%nu + 1:), c%holdout, theil, rms, &
                                                     ratio)
    json = json(1:len(json) - 1)//','//achar(10)// &
           validation_json(names(c%nu + 1:), c%holdout, theil, rms, ratio)//'}'
  end subroutine validate_case

  !> Case c with only the data files where keep is true.
  function files_of(c, keep) result(part)
    type(case_t), intent(in) :: c
    logical, intent(in) :: keep(:)
    type(case_t) :: part
    part = c
    part%data_files = pack(c%data_files, keep)
    part%file_no = pack(c%file_no, keep)          ! the manoeuvre channel keeps its number
    part%win_start = pack(c%win_start, keep)
    part%win_end = pack(c%win_end, keep)
  end function files_of

  !> The outputs of case h (nothing free) on each manoeuvre, simulated
  !> without noise.
  subroutine predict(h, t, u, segstart, y, cstat, cmsg)
    type(case_t), intent(in) :: h
    real(wp), intent(in) :: t(:), u(:, :)
    integer, intent(in) :: segstart(:)
    real(wp), allocatable, intent(out) :: y(:, :)
    integer, intent(out) :: cstat
    character(len=*), intent(out) :: cmsg
    real(wp), allocatable :: x(:, :)
    integer :: j, i0, i1

    allocate (y(h%ny, size(t)), x(h%nx, size(t)))
    cstat = MLID_OK
    do j = 1, size(segstart)
      i0 = segstart(j)
      i1 = size(t)
      if (j < size(segstart)) i1 = segstart(j + 1) - 1
      call mlid_simulate(h%mkind, h%nx, h%nu, h%ny, h%nw, size(h%theta), h%theta, &
                         size(h%iconst), h%iconst, size(h%rconst), h%rconst, i1 - i0 + 1, &
                         t(i0:i1), u(:, i0:i1), 0, 0, h%iopt, h%ropt, y(:, i0:i1), x(:, i0:i1), &
                         cstat, cmsg)
      if (cstat /= MLID_OK) return
    end do
  end subroutine predict

  !> An optional array, or zeros of the size the interface wants.
  function or_zero(a, n) result(out)
    real(wp), allocatable, intent(in) :: a(:)
    integer, intent(in) :: n
    real(wp) :: out(n)
    out = 0.0_wp
    if (allocated(a)) out = a
  end function or_zero

  function weight_or_zero(a, n) result(out)
    real(wp), allocatable, intent(in) :: a(:, :)
    integer, intent(in) :: n
    real(wp) :: out(n, n)
    out = 0.0_wp
    if (allocated(a)) out = a
  end function weight_or_zero

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
