!> The job runner: run_case runs one case of a deck, whatever its job
!> (estimate, validate, and those of mlid_jobs: simulate, design,
!> monte_carlo), and gives back what the case prints (its report lines),
!> its JSON object and its notes (warnings and the failure, one line each,
!> for the front end to print on stderr after its own prefix).  Files the
!> case writes (records, corrected records) are written here, whole or not
!> at all.  mlid-batch is a loop over a deck's cases calling it.
module mlid_run
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_NOCONV, fit_outcome, FIT_ESTIMATES, FIT_FAILED, &
                        FIT_NOT_RUN, msg_len
  use mlid_case, only: case_t, NAMELEN
  use mlid_text, only: line_t, itoa, add_line
  use mlid_units, only: UNITLEN
  use mlid_deck, only: case_record, manoeuvre_layout, case_param_units, holdout_case, &
                       manoeuvre_block, corrected_writable
  use mlid_validate, only: prediction_stats
  use mlid_initial_states, only: x0_from_record
  use mlid_equations, only: equations_t, equations_create, equations_tables
  use mlid_models, only: model_t
  use mlid_model_factory, only: model_create
  use mlid_flightpath, only: flightpath_corrected
  use mlid_params, only: param_map_t, free_indices
  use mlid_options, only: options_t
  use mlid_newton, only: fit_result_t
  use mlid_fit_driver, only: fit_solve, fit_view, fit_view_t
  use mlid_named, only: named_t
  use mlid_simulate, only: simulate_flat
  use mlid_jobs, only: job_run, JOB_RUNS, around_t, hook_t   ! the hooks: mlid_jobs's
  use mlid_progress, only: progress_t
  use mlid_files, only: temporary_for, write_whole
  use mlid_record, only: record_text
  use mlid_report, only: CELLLEN, fit_summary_t, fit_report, fit_json, case_json, &
                         validation_report, validation_json
  implicit none
  private
  public :: case_run_t, run_case, corrected_record, put_fit, around_t, hook_t

  !> What running a case gave.
  type :: case_run_t
    character(len=:), allocatable :: report   !< its lines for stdout (after its heading)
    character(len=:), allocatable :: json     !< its JSON object
    type(line_t), allocatable :: notes(:)     !< warnings and the failure, for stderr
    integer :: status = MLID_OK               !< of the case: a fit that did not converge is OK
    character(len=256) :: msg = ''
    !> a fit's numbers by name (put_fit), for a front end to read: what
    !> mlid_fit_driver's fit_view_t holds, and a validation's statistics
    type(named_t) :: results
    type(around_t) :: around                  !< run_case's hooks around a fit
    !> the progress of its long work while it runs (mlid_progress), when a
    !> front end shows it; not associated: not counted
    type(progress_t), pointer :: progress => null()
  end type case_run_t

  character, parameter :: NL = achar(10)
  !> Samples from which a fit's record is noted as long (an hour at 50 Hz;
  !> a manoeuvre is a few thousand): a fit of it takes seconds to minutes.
  integer, parameter :: LONG_RECORD = 200000

contains

  !> Run case c.  A failed case has its message as the last note, and a
  !> ' FAILED:' line ends its report unless a failed fit's report says it.
  !> around: the hooks around its numerical work; progress: where that
  !> work counts its steps, for a front end to show (mlid_progress).
  subroutine run_case(c, r, around, progress)
    type(case_t), intent(inout) :: c
    type(case_run_t), intent(out) :: r
    type(around_t), intent(in), optional :: around
    type(progress_t), intent(inout), target, optional :: progress
    character(len=:), allocatable :: json, report, text
    integer :: outcome

    r%report = ''
    allocate (r%notes(0))
    if (present(around)) r%around = around
    if (present(progress)) r%progress => progress
    r%status = c%status
    r%msg = c%msg
    outcome = FIT_NOT_RUN
    if (r%status /= MLID_OK) then
      continue
    else if (index(JOB_RUNS, ' '//trim(c%job)//' ') > 0) then
      call job_run(c, report, text, r%status, r%msg, r%around, r%progress)   ! null: absent (F2008)
      if (r%status == MLID_OK) then
        r%report = report
        json = text
      end if
    else if (c%job == 'validate') then
      call validate_case(c, r, json, outcome)
    else
      call fit_case(c, r, json, outcome)
    end if
    ! a job that stopped before its result has only its message to give
    if (.not. allocated(json)) json = case_json(c%title, c%job, r%status, r%msg)
    r%json = json
    r%progress => null()            ! the caller's, for this run only
    if (r%status /= MLID_OK) then
      call note(r, r%msg)
      ! a failed fit's report ends with this line already
      if (outcome /= FIT_FAILED) r%report = r%report//' FAILED: '//trim(r%msg)//NL
    end if
  end subroutine run_case

  subroutine note(r, text)
    type(case_run_t), intent(inout) :: r
    character(len=*), intent(in) :: text
    call add_line(r%notes, text)
  end subroutine note

  subroutine notes_from(r, notes)
    type(case_run_t), intent(inout) :: r
    type(line_t), allocatable, intent(in) :: notes(:)
    integer :: j
    if (.not. allocated(notes)) return
    do j = 1, size(notes)
      call note(r, notes(j)%s)
    end do
  end subroutine notes_from

  !> Fit an estimate case and write its corrected records.  A fit that did
  !> not converge is a result with a warning, not a failure of the case.
  subroutine fit_case(c, r, json, outcome)
    type(case_t), intent(inout) :: c
    type(case_run_t), intent(inout) :: r
    character(len=:), allocatable, intent(out) :: json
    integer, intent(out) :: outcome       !< of the fit (mlid_kinds FIT_*)
    real(wp), allocatable :: t(:), u(:, :), y(:, :), theta(:), rhat(:, :), yhat(:, :), own_t(:)
    integer, allocatable :: segstart(:)
    character(len=UNITLEN), allocatable :: units(:)
    character(len=NAMELEN), allocatable :: names(:)
    type(line_t), allocatable :: notes(:)

    outcome = FIT_NOT_RUN
    call case_record(c, t, u, y, r%status, r%msg, segstart, units, names, notes=notes, &
                     own_t=own_t, progress=r%progress)
    call notes_from(r, notes)
    if (r%status == MLID_OK) call corrected_writable(c, r%status, r%msg)   ! before a long fit
    if (r%status == MLID_OK) call fit_record(c, t, u, y, segstart, units, r, json, theta, rhat, &
                                             yhat, outcome, names)
    if (allocated(c%corrected)) then
      if (r%status == MLID_OK) then
        call write_corrected(c, own_t, u, y, segstart, units, theta, r)
        if (r%status /= MLID_OK) deallocate (json)   ! the case failed: its message, not the fit's
      else if (outcome == FIT_ESTIMATES) then        ! not converged, reported
        r%report = r%report//' corrected records not written: the fit did not end well'//NL
      end if
    end if
    if (r%status == MLID_ERR_NOCONV .and. outcome == FIT_ESTIMATES) then
      call note(r, 'warning: '//r%msg)
      r%status = MLID_OK
    end if
  end subroutine fit_case

  !> Each manoeuvre's record with the fit's corrections undone, written
  !> where &estimate corrected says, its channels named as the model names
  !> its inputs and outputs.
  subroutine write_corrected(c, t, u, y, segstart, units, theta, r)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: t(:)                !< each manoeuvre's own time (its file's)
    real(wp), intent(in) :: u(:, :), y(:, :), theta(:)
    integer, intent(in) :: segstart(:)
    character(len=*), intent(in) :: units(:)
    type(case_run_t), intent(inout) :: r
    real(wp), allocatable :: uc(:, :), yc(:, :)
    integer :: j, j0, j1, n

    do j = 1, size(segstart)
      j0 = segstart(j)
      j1 = size(t)
      if (j < size(segstart)) j1 = segstart(j + 1) - 1
      n = j1 - j0 + 1
      allocate (uc(c%nu, n), yc(c%ny, n))
      call corrected_record(c%iconst, manoeuvre_block(c, size(segstart), theta, j, 'p'), &
                            manoeuvre_block(c, size(segstart), theta, j, 'bias'), &
                            manoeuvre_block(c, size(segstart), theta, j, 'delay'), &
                            manoeuvre_block(c, size(segstart), theta, j, 'udelay'), t(j0:j1), &
                            u(:, j0:j1), y(:, j0:j1), [c%input_names, c%output_names], units, &
                            trim(c%corrected(j)), uc, yc, r%status, r%msg)
      if (r%status /= MLID_OK) return
      r%report = r%report//' corrected record of manoeuvre '//itoa(j)//' written to '// &
                 trim(c%corrected(j))//NL
      deallocate (uc, yc)
    end do
  end subroutine write_corrected

  !> One manoeuvre of a flight-path model's fit with its corrections undone
  !> (mlid_flightpath's flightpath_corrected): the model by its text
  !> (iconst), its corrections p, the manoeuvre's output biases and delays
  !> and input delays, its record (t, u, y) -> uc, yc; when path is not
  !> blank, also written there whole or not at all (record_text: the
  !> channels' names and units, inputs then outputs).
  subroutine corrected_record(iconst, p, bias, delay, udelay, t, u, y, names, units, path, uc, yc, &
                              status, msg)
    integer, intent(in) :: iconst(:)
    real(wp), intent(in) :: p(:), bias(:), delay(:), udelay(:), t(:), u(:, :), y(:, :)
    character(len=*), intent(in) :: names(:), units(:), path
    real(wp), intent(out) :: uc(:, :), yc(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(equations_t) :: eqs
    character(len=:), allocatable :: tmp, text

    uc = u
    yc = y
    call equations_create(iconst, [real(wp) ::], eqs, status, msg)
    if (status /= MLID_OK) then
      msg = 'corrected record: not a flight-path model ('//trim(msg)//')'
      return
    end if
    call flightpath_corrected(eqs%unames, eqs%pnames, p, eqs%ynames, bias, delay, udelay, t, uc, &
                              yc, status, msg)
    if (status /= MLID_OK .or. len_trim(path) == 0) return
    call temporary_for(trim(path), tmp, status, msg)
    if (status == MLID_OK) call record_text(names, units, t, uc, yc, text, status, msg)
    if (status == MLID_OK) call write_whole(trim(path), tmp, text, status, msg)
  end subroutine corrected_record

  !> Fit case c to a record (several manoeuvres: segstart); with json
  !> present, add its report to r and return its JSON object.  theta, R-hat
  !> and the outputs of the fit are returned.
  subroutine fit_record(c, t, u, y, segstart, units, r, json, theta, rhat, yhat, outcome, names)
    type(case_t), intent(inout) :: c
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    integer, intent(in) :: segstart(:)
    character(len=*), intent(in) :: units(:)       !< the channels': inputs, then outputs
    character(len=*), intent(in), optional :: names(:)   !< the channels' names, as units
    type(case_run_t), intent(inout) :: r
    character(len=:), allocatable, intent(out), optional :: json
    real(wp), allocatable, intent(out) :: theta(:), rhat(:, :), yhat(:, :)
    integer, intent(out) :: outcome       !< of the fit (mlid_kinds FIT_*)
    type(fit_result_t) :: res
    type(param_map_t) :: pm
    type(options_t) :: opt
    type(fit_summary_t) :: s
    type(fit_view_t) :: v
    integer :: bad, nth, nf
    integer(int64) :: clock0, clock1, rate      !< the fit's wall time (FitResult.wall_time)

    outcome = FIT_NOT_RUN
    call case_param_units(c, size(segstart), units, s%units, r%status, r%msg)
    if (present(names)) then                  ! the outputs, named under R's diagonal
      s%outputs = names(size(u, 1) + 1:)
      s%output_units = units(size(u, 1) + 1:)
    end if
    ! several data files: several manoeuvres, each its own x0 and biases
    if (r%status == MLID_OK) call manoeuvre_layout(c, size(segstart), r%status, r%msg)
    ! &estimate x0_from: each manoeuvre's measured states start at its record's
    if (r%status == MLID_OK .and. len_trim(c%x0_from) > 0) &
      call x0_from_record(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, c%theta, y, &
                          segstart, c%x0_from, c%x0_samples, r%status, r%msg)
    if (r%status /= MLID_OK) return
    nth = size(c%theta)
    nf = count(c%isfree > 0)
    if (size(t) >= LONG_RECORD) call note(r, 'a long record: '//itoa(size(t))//' samples of '// &
      itoa(size(u, 1) + size(y, 1) + 1)//' channels ('//itoa(nint(8.0e-6_wp*size(t)* &
      (size(u, 1) + size(y, 1) + 1)))//' MB of numbers) and '//itoa(nf)//' free parameters: '// &
      'the fit takes longer than a manoeuvre''s')
    call system_clock(clock0, rate)
    if (associated(r%around%begin)) call r%around%begin()
    call fit_solve(c%mkind, c%nx, c%nu, c%ny, c%nw, c%theta, c%isfree, c%tie, c%iconst, c%rconst, &
                   t, u, y, segstart, c%iopt, c%ropt, nf, c%use_prior, or_zero(c%prior, nth), &
                   weight_or_zero(c%pweight, nf), c%use_bounds, or_zero(c%lower, nth), &
                   or_zero(c%upper, nth), res, pm, opt, bad, r%status, r%msg, r%progress)
    if (associated(r%around%end)) call r%around%end()
    call system_clock(clock1)
    v = fit_view(res, pm, opt, c%theta, c%ny, size(t), bad)
    call summary(c, v, s)
    theta = v%theta
    rhat = v%rhat
    yhat = v%yhat
    if (r%status /= MLID_OK .and. v%bad > 0) r%msg = replace_index(r%msg, v%bad, c%labels)
    ! a fit that ran has a report: its estimates, or its last values if it failed
    outcome = fit_outcome(r%status, s%reason)
    if (outcome == FIT_NOT_RUN .or. .not. present(json)) return
    call put_fit(r%results, v, r%status, r%msg)
    call r%results%put('wall_time', real(clock1 - clock0, wp)/real(max(rate, 1_int64), wp))
    r%report = r%report//fit_report(s, c%iopt, c%ropt, r%status, r%msg)
    json = fit_json(c%title, c%job, r%status, r%msg, s, c%iopt, c%ropt)
    if (r%status == MLID_OK .and. r%msg(1:min(8, len(r%msg))) == 'warning:') call note(r, r%msg)
  end subroutine fit_record

  !> Fit v by name, as the flat interface's fit gives it (mlid_api_fit's
  !> mlid_fit): theta_start, theta, sigma, ... over every parameter.
  subroutine put_fit(results, v, status, msg)
    type(named_t), intent(inout) :: results
    type(fit_view_t), intent(in) :: v
    integer, intent(in) :: status
    character(len=*), intent(in) :: msg
    call results%put('theta_start', v%theta_start)
    call results%put('theta', v%theta)
    call results%put('sigma', v%sigma)
    call results%put('sigma_corrected', v%sigma_c)
    call results%put('covariance', v%cov)
    call results%put('covariance_corrected', v%cov_c)
    call results%put('information', v%info)
    call results%put('gradient', v%grad)
    call results%put('eigenvalues', v%eigval)
    call results%put('eigenvectors', v%eigvec)
    call results%put('rhat', v%rhat)
    call results%put('yhat', v%yhat)
    call results%put('cost_history', v%hist)
    call results%put('cost', v%cost)
    call results%put('iterations', v%niter)
    call results%put('reason', v%reason)
    call results%put('converged', v%converged)
    call results%put('rank', v%rank)
    call results%put('bad_param', v%bad)
    call results%put('colored_lag', v%lag)
    call results%put('r_innovations', v%rnoise)
    call results%put('status', status)
    call results%put('message', trim(msg))
  end subroutine put_fit

  !> The report's view of fit v of case c: the free parameters' values.
  subroutine summary(c, v, s)
    type(case_t), intent(in) :: c
    type(fit_view_t), intent(in) :: v
    type(fit_summary_t), intent(inout) :: s
    integer, allocatable :: free(:)

    free = free_indices(c%isfree)
    s%labels = c%labels
    s%start = v%theta_start(free)
    s%est = v%theta(free)
    s%sig = v%sigma(free)
    s%sigc = v%sigma_c(free)
    s%cov = v%cov
    s%eigval = v%eigval
    s%eigvec = v%eigvec
    s%rhat = v%rhat
    s%hist = v%hist(1:v%niter + 1)
    s%cost = v%cost
    s%niter = v%niter
    s%reason = v%reason
    s%rank = v%rank
    s%lag = v%lag
    s%converged = v%converged
    if (all(ieee_is_finite(v%rnoise))) s%rnoise = v%rnoise
    if (size(v%kc) > 0) s%kc = v%kc
    call unreached_cells(c, v%info, free, s)
  end subroutine summary

  !> The free table values of case c's model that no sample reaches, into
  !> s: their row of the information info (free x free) is zero, as every
  !> hat weight is zero at every sample (mlid_tables); each said with where
  !> it acts (equations_tables' text).  None for a model without tables, or
  !> when info is not the fit's (a failed fit) or a prior fills it.
  subroutine unreached_cells(c, info, free, s)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: info(:, :)
    integer, intent(in) :: free(:)
    type(fit_summary_t), intent(inout) :: s
    class(model_t), allocatable :: m
    character(len=CELLLEN), allocatable :: texts(:), said(:)
    character(len=32), allocatable :: labels(:)
    real(wp), allocatable :: w(:, :)
    integer :: j, k, status, ntab
    character(len=msg_len) :: msg
    logical, allocatable :: none(:)

    ! every early return leaves the lists empty: only the report's list is lost, the fit stands
    allocate (s%unreached(0), s%unreached_labels(0), stat=status)
    if (status /= 0) return
    if (size(info, 1) /= size(free) .or. size(info, 2) /= size(free)) return
    call model_create(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, m, status, msg)
    if (status /= MLID_OK) return
    ntab = 0
    select type (m)
    type is (equations_t)
      ntab = size(m%tables)
    end select
    if (ntab == 0) return
    allocate (texts(m%np), w(m%np, m%np), none(size(free)), stat=status)
    if (status /= 0) return
    call equations_tables(m, [(0.0_wp, k=1, ntab)], texts, w, status, msg)
    if (status /= MLID_OK) return
    none = .false.
    do k = 1, size(free)
      if (free(k) > m%np) cycle
      none(k) = len_trim(texts(free(k))) > 0 .and. all(info(k, :) == 0.0_wp)
    end do
    allocate (said(count(none)), labels(count(none)), stat=status)
    if (status /= 0) return
    j = 0
    do k = 1, size(free)
      if (.not. none(k)) cycle
      j = j + 1
      said(j) = trim(texts(free(k)))//' is reached by no sample: not identifiable'
      labels(j) = s%labels(k)
    end do
    call move_alloc(said, s%unreached)
    call move_alloc(labels, s%unreached_labels)
  end subroutine unreached_cells

  !> Validate case c: fit on the files not held out (reported as an estimate
  !> case is), then predict the held-out ones (holdout_case) and say how well.
  subroutine validate_case(c, r, json, outcome)
    type(case_t), intent(inout) :: c
    type(case_run_t), intent(inout) :: r
    character(len=:), allocatable, intent(out) :: json
    integer, intent(out) :: outcome       !< of the fit (mlid_kinds FIT_*)
    real(wp), allocatable :: t(:), u(:, :), y(:, :), theta(:), rhat(:, :), yhat(:, :), r0(:, :)
    real(wp), allocatable :: th(:), uh(:, :), yh(:, :), pred(:, :), theil(:), rms(:), ratio(:)
    integer, allocatable :: segstart(:), sh(:)
    character(len=UNITLEN), allocatable :: units(:), hunits(:), shown(:)
    character(len=NAMELEN), allocatable :: names(:), fnames(:)
    real(wp), allocatable :: scale(:)
    type(line_t), allocatable :: notes(:)
    type(case_t) :: fitted, held
    logical, allocatable :: out(:)
    integer :: held_outcome

    outcome = FIT_NOT_RUN
    allocate (out(size(c%data_files)))
    out = .false.
    out(c%holdout) = .true.
    ! every part read before the fit: the files fitted, then those held out
    fitted = files_of(c, .not. out)
    call case_record(fitted, t, u, y, r%status, r%msg, segstart, units, fnames, notes=notes, &
                     progress=r%progress)
    call notes_from(r, notes)
    if (r%status == MLID_OK) call case_record(files_of(c, out), th, uh, yh, r%status, r%msg, sh, &
                                              hunits, names, notes, shown=shown, scale=scale, &
                                              progress=r%progress)
    if (r%status == MLID_OK) call notes_from(r, notes)
    if (r%status == MLID_OK) call fit_record(fitted, t, u, y, segstart, units, r, json, theta, &
                                             rhat, yhat, outcome, fnames)
    if (r%status /= MLID_OK) return
    call holdout_case(files_of(c, out), theta, count(.not. out), held, r%status, r%msg)
    if (r%status /= MLID_OK) return
    if (count(held%isfree > 0) > 0) then
      call fit_record(held, th, uh, yh, sh, hunits, r, theta=theta, rhat=r0, yhat=pred, &
                      outcome=held_outcome)
    else
      call predict(held, th, uh, yh, sh, pred, r%status, r%msg)
    end if
    if (r%status /= MLID_OK) then         ! the case failed: its JSON says why, not the fit's
      r%msg = 'prediction of the held-out files: '//trim(r%msg)
      deallocate (json)
      return
    end if
    allocate (theil(c%ny), rms(c%ny), ratio(c%ny))
    call prediction_stats(yh, pred, rhat, theil, rms, ratio)
    if (allocated(c%output_names)) then
      if (all(len_trim(c%output_names) > 0)) names(c%nu + 1:) = c%output_names
    end if
    r%report = r%report//validation_report(names(c%nu + 1:), shown(c%nu + 1:), &
                                           scale(c%nu + 1:), c%holdout, theil, rms, ratio)
    call r%results%put('theil', theil)
    call r%results%put('rms', rms)
    call r%results%put('rms_over_sigma', ratio)
    call r%results%put('prediction', pred)
    json = json(1:len(json) - 1)//','//NL// &
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
  !> without noise (x0_from: each from its measured states' x0 of ym).
  subroutine predict(h, t, u, ym, segstart, y, status, msg)
    type(case_t), intent(in) :: h
    real(wp), intent(in) :: t(:), u(:, :), ym(:, :)
    integer, intent(in) :: segstart(:)
    real(wp), allocatable, intent(out) :: y(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: x(:, :), theta(:)
    integer :: j, i0, i1

    allocate (y(h%ny, size(t)), x(h%nx, size(t)))
    status = MLID_OK
    do j = 1, size(segstart)
      i0 = segstart(j)
      i1 = size(t)
      if (j < size(segstart)) i1 = segstart(j + 1) - 1
      theta = h%theta
      if (len_trim(h%x0_from) > 0) call x0_from_record(h%mkind, h%nx, h%nu, h%ny, h%nw, &
        h%iconst, h%rconst, theta, ym(:, i0:i1), [1], h%x0_from, h%x0_samples, status, msg)
      if (status /= MLID_OK) return
      call simulate_flat(h%mkind, h%nx, h%nu, h%ny, h%nw, theta, h%iconst, h%rconst, &
                         t(i0:i1), u(:, i0:i1), h%iopt, h%ropt, 0, y(:, i0:i1), x(:, i0:i1), &
                         status, msg)
      if (status /= MLID_OK) return
    end do
  end subroutine predict

  !> An optional array, or zeros of the size the fit wants.
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

end module mlid_run
